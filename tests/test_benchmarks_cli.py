"""Every benchmark script (``benchmarks/*.py`` but the ``_``-prefixed helpers) answers ``--help`` with exit 0,
a description of what it measures and a help text for each of its options.

Each runs as a person runs it (``python benchmarks/NAME.py --help``: ``__main__``, its directory first on
``sys.path``), from a directory that is not the checkout, all of them one after the other in one interpreter
(``tests/cli_in_process.py``: a Python start each cost the suite 0.3 CPU s); no benchmark is actually run here
(they take minutes; benchmarks/README.md has their figures).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from cli_in_process import run_scripts  # tests/cli_in_process.py

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p for p in BENCHMARKS.glob("*.py") if not p.name.startswith("_"))


def undocumented_options(help_text: str) -> list[str]:
    """The options argparse lists under ``options:`` without a help text (on their line or the next)."""
    lines = help_text.split("options:", 1)[1].splitlines()
    missing = []
    for k, line in enumerate(lines):
        if not line.startswith("  -"):
            continue
        flags, gap, text = line.strip().partition("  ")
        following = lines[k + 1] if k + 1 < len(lines) else ""
        has_help = text.strip() if gap else following.startswith("    ") and following.strip()
        if not has_help:
            missing.append(flags)
    return missing


def test_the_benchmarks_are_found():
    names = {p.stem for p in SCRIPTS}
    assert {"flight_benchmark", "landing_benchmark", "vehicle_benchmark", "estimator_cost", "profile_lockstep"} <= names


def test_undocumented_options_finds_an_option_without_help():
    text = "options:\n  -h, --help  show this help\n  --bare BARE\n  --long-one LONG_ONE\n      its help\n"
    assert undocumented_options(text) == ["--bare BARE"]


@pytest.fixture(scope="module")
def helps(tmp_path_factory) -> tuple[dict, Path]:
    """Every script's ``--help`` (a ``CompletedProcess`` by script), and the directory they ran in."""
    cwd = tmp_path_factory.mktemp("benchmark-helps")
    done = run_scripts([[str(script), "--help"] for script in SCRIPTS], cwd)
    return dict(zip(SCRIPTS, done)), cwd


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_help_describes_the_benchmark_and_every_option(script: Path, helps):
    r = helps[0][script]
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert r.stdout.startswith(f"usage: {script.name}")
    summary = r.stdout.split("\n\n")[1]  # the docstring's first paragraph: what it measures
    assert len(summary.split()) >= 6, summary
    assert "benchmarks/README.md" in r.stdout
    assert undocumented_options(r.stdout) == []
    assert list(helps[1].iterdir()) == [], "a --help wrote a file"
