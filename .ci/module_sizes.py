"""A guide, not a gate: the largest Python modules of the project, printed in CI's output.

Modules are cut by meaning (one idea each), not by a line count (issue 37 replaced the hard 400-line test with
this report).  A module near the top of this list is worth a look when it is next changed: does it still hold
one idea?  ``python .ci/module_sizes.py [N]`` prints the N largest (default 15); the exit status is always 0.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("mavsim_core", "autopilot", "sitl", "gcs", "params", "vision", "campaign", "tests", "benchmarks")
GUIDE_LINES = 400  # where a module is worth a look, not a limit


def sizes() -> list[tuple[int, str]]:
    """(lines, path relative to the project) of every Python file in the packages, largest first."""
    files = (p for pkg in PACKAGES if (ROOT / pkg).is_dir() for p in (ROOT / pkg).rglob("*.py"))
    found = [(len(p.read_text().splitlines()), str(p.relative_to(ROOT))) for p in files if "__pycache__" not in p.parts]
    return sorted(found, reverse=True)


def main(argv: list[str]) -> int:
    n = int(argv[0]) if argv else 15
    found = sizes()
    over = sum(1 for lines, _ in found if lines > GUIDE_LINES)
    print(f"{len(found)} Python modules, {sum(x for x, _ in found)} lines; {over} over {GUIDE_LINES} lines. Largest:")
    for lines, path in found[:n]:
        print(f"  {lines:5d}  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
