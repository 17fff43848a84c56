"""The shape the code keeps: short functions.

No function of the project (source, tests, benchmarks) is over 80 lines, so each step of the lockstep path
reads on one screen.  Modules are cut by meaning, not by size: their sizes are a guide that CI prints
(``.ci/module_sizes.py``), not a test.  Reads the files; runs nothing.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("mavsim_core", "autopilot", "sitl", "gcs", "params", "vision", "tests", "benchmarks")
MAX_FUNCTION_LINES = 80


def python_files() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py") if "__pycache__" not in p.parts)


def test_there_are_files_to_check():
    assert len(python_files()) > 100


def test_no_function_over_80_lines():
    long = {}
    for p in python_files():
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long[f"{p.relative_to(ROOT)}:{node.lineno} {node.name}"] = n
    assert long == {}
