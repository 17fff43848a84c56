"""Benchmark: one benchmark script on an older revision and on this checkout, in the same run, side by side.

Any benchmark's figures, before and after a change, measured on the same machine at the same time: the
older revision is exported (``git archive``) into a temporary directory and its copy of the script runs
with that directory first on ``PYTHONPATH`` (the processes it starts run ``python -m`` with the same
path, so the whole stack is the old one); then this checkout's script runs with the same arguments.
With ``--rounds N`` the two alternate N times (before, after, before, after, ...), so a change in the
machine's load hits both alike.  Each run's stdout is printed under a header naming the revision, and
at the end the wall seconds of each run.

Both runs use the same instance number (they never run at the same time); give the benchmark's own
``-i N`` after ``--`` to choose it.  The older revision must have the script and its options.

Usage: ``python benchmarks/before_after.py --before 49e60b3 -- vehicle_benchmark.py --vehicles quad_x``
"""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

from _cli import parser

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def export_revision(rev: str, dest: Path) -> str:
    """The tree of ``rev`` written under ``dest`` (no git state is changed); returns its short hash."""
    short = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, capture_output=True, text=True, check=False)
    if short.returncode != 0:
        raise SystemExit(f"before_after: --before: no revision {rev!r} in {ROOT}")
    archive = subprocess.run(["git", "archive", "--format=tar", rev], cwd=ROOT, capture_output=True, check=True)
    with tarfile.open(fileobj=BytesIO(archive.stdout)) as tar:
        tar.extractall(dest, filter="data")
    return short.stdout.strip()


def run_one(label: str, tree: Path, script: str, args: list[str], cwd: Path) -> float:
    """Run ``tree/benchmarks/script`` with ``tree`` first on PYTHONPATH, in ``cwd`` (relative output paths such
    as ``--out`` land there); print its stdout; its wall seconds."""
    path = tree / "benchmarks" / script
    if not path.is_file():
        raise SystemExit(f"before_after: {label} has no benchmarks/{script}")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tree), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    print(f"\n===== {label}: {script} {' '.join(args)}", flush=True)
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, str(path), *args], cwd=cwd, env=env, check=False)
    wall = time.monotonic() - t0
    if r.returncode != 0:
        print(f"===== {label}: exit {r.returncode}", flush=True)
    return wall


def main() -> int:
    ap = parser(__doc__, progress=False)
    ap.add_argument("--before", default="49e60b3", help="the older revision (any git revision name)")
    ap.add_argument("--rounds", type=int, default=1, help="how many times the before/after pair runs")
    ap.add_argument("script", help="the benchmark's file name in benchmarks/, e.g. vehicle_benchmark.py")
    ap.add_argument("args", nargs="*", help="the benchmark's own options (after --)")
    a = ap.parse_args()
    if a.rounds < 1:
        ap.error("--rounds: must be at least 1")
    walls: dict[str, list[float]] = {"before": [], "after": []}
    with tempfile.TemporaryDirectory(prefix="before_after_") as tmp:
        base = Path(tmp) / "tree"
        short = export_revision(a.before, base)
        for k in range(a.rounds):
            for side, label, tree in (("before", f"before ({short})", base), ("after", "after (this checkout)", ROOT)):
                cwd = Path(tmp) / f"{side}_run{k}"
                cwd.mkdir()
                walls[side].append(run_one(label, tree, a.script, a.args, cwd))
    print("\nwall seconds per run: " + "; ".join(f"{k} {', '.join(f'{w:.1f}' for w in v)}" for k, v in walls.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
