"""Flake hunt: run chosen tests N times, under load, and print each test's failures and its figures' spread.

A test that fails once on correct code is a broken test.  This runs the selection (default: every end-to-end
test, ``-m e2e``) ``--runs`` times through pytest, each run a whole pytest invocation with the suite's own
options (pytest-xdist, ``--dist loadfile``), ``--parallel`` runs at a time (2: two suites side by side, as a
loaded CI machine sees) and ``--load`` extra processes spinning on the CPU meanwhile.  Every run writes a
JUnit XML file (which tests failed, and why) and the figures the tests assert through
``record_figure`` (tests/e2e_flight_helpers.py: ``E2E_FIGURES`` points each run at its own file).

It prints, per test: runs, failures (with the first line of each distinct failure) and, per figure, its
minimum, median and maximum over the runs, its limit and the margin of the worst run to the limit.  With
``--seeds`` run k flies with simulator seed k (``E2E_SEED``): the flights in simulated time are then exactly
reproducible within a seed, and the spread over seeds is the spread of the sensors' noise, which is what a
limit must allow for.  ``--markdown`` prints the tables as Markdown (docs/testing.md holds the last ones).

Usage:
    python benchmarks/flake_hunt.py --runs 20 --parallel 2                       # the whole e2e set
    python benchmarks/flake_hunt.py --runs 20 --seeds tests/test_e2e_failure_detection.py
    python benchmarks/flake_hunt.py --runs 5 --load 1 -k drifting tests/test_e2e_failure_detection.py
    python benchmarks/flake_hunt.py --runs 4 --parallel 2 --seeds --out /work/hunt   # 4 more runs in a kept DIR
    python benchmarks/flake_hunt.py --report /tmp/hunt --markdown   # the tables of a kept --out directory
"""

from __future__ import annotations

import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from _cli import parser

ROOT = Path(__file__).resolve().parent.parent


def _spin() -> None:  # a load process: one core busy until killed
    while True:
        pass


def commit() -> str:
    """The commit the runs test, as ``git describe --always --dirty`` prints it ("unknown" outside a clone)."""
    done = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True)
    return done.stdout.strip() or "unknown"


def run_indices(out: Path) -> list[int]:
    """The run numbers already in ``out`` (from its ``run-K.xml`` files), sorted."""
    found = []
    for path in out.glob("run-*.xml"):
        with contextlib.suppress(ValueError):
            found.append(int(path.stem.removeprefix("run-")))
    return sorted(found)


def run_once(k: int, args, out: Path) -> tuple[int, float, str]:
    """Run pytest once (run ``k``); (exit status, wall seconds, the summary line).  Writes ``run-K.json``."""
    env = dict(os.environ)
    env["E2E_FIGURES"] = str(out / f"figures-{k}.jsonl")
    env["E2E_DIAGNOSTICS"] = str(out / f"diagnostics-{k}.txt")  # a failed e2e test's log tails and last messages
    seed = args.first_seed + k if args.seeds else None
    if seed is not None:
        env["E2E_SEED"] = str(seed)
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={out / f'run-{k}.xml'}"]
    if args.jobs is not None:
        cmd += ["-n", str(args.jobs)]
    if args.k:
        cmd += ["-k", args.k]
    cmd += args.tests or ["-m", "e2e", "tests"]
    t0 = time.monotonic()
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.monotonic() - t0
    lines = [ln for ln in done.stdout.splitlines() if ln.strip()]
    summary = lines[-1] if lines else done.stderr[-300:]
    meta = {"run": k, "commit": args.commit, "seed": seed, "exit": done.returncode, "wall_s": round(wall, 1)}
    (out / f"run-{k}.json").write_text(json.dumps({**meta, "summary": summary}) + "\n")
    return done.returncode, wall, summary


def node_id(classname: str, name: str) -> str:
    """The node id of a JUnit case: ``tests.test_x.TestY``, ``test_z`` -> ``tests/test_x.py::TestY::test_z``."""
    parts = classname.split(".")
    module = max((i for i, p in enumerate(parts) if p.startswith("test_")), default=len(parts) - 1)
    return "::".join(["/".join(parts[: module + 1]) + ".py", *parts[module + 1 :], name])


def read_results(out: Path, runs: list[int]):
    """Per test node id: (passed, failed, [distinct first lines of failures], [wall seconds])."""
    tests: dict[str, dict] = defaultdict(lambda: {"passed": 0, "failed": 0, "why": [], "times": []})
    for k in runs:
        path = out / f"run-{k}.xml"
        if not path.exists():
            continue
        for case in ET.parse(path).getroot().iter("testcase"):
            node = node_id(case.get("classname", ""), case.get("name", ""))
            t = tests[node]
            bad = [c for c in case if c.tag in ("failure", "error")]
            if any(c.tag == "skipped" for c in case):
                continue
            t["times"].append(float(case.get("time", 0.0)))
            if bad:
                t["failed"] += 1
                first = (bad[0].get("message") or bad[0].text or "").strip().splitlines()
                why = f"run {k}: {first[0][:160] if first else bad[0].tag}"
                t["why"].append(why)
            else:
                t["passed"] += 1
    return tests


def read_figures(out: Path, runs: list[int]):
    """Per (test, figure name): the values over the runs, the limit, below-or-above, unit."""
    figures: dict[tuple[str, str], dict] = {}
    for k in runs:
        path = out / f"figures-{k}.jsonl"
        if not path.exists():
            continue
        for line in path.read_text().splitlines():
            try:
                f = json.loads(line)
            except json.JSONDecodeError:
                continue
            key = (f["test"], f["name"])
            entry = figures.setdefault(key, {"values": [], "limit": f["limit"], "below": f["below"], "unit": f["unit"]})
            entry["values"].append(float(f["value"]))
    return figures


def margin(entry) -> float:
    """How far the worst run is from the limit, as a fraction of the limit's distance from zero (+: inside)."""
    values, limit = entry["values"], entry["limit"]
    worst = max(values) if entry["below"] else min(values)
    return (limit - worst) / abs(limit) if entry["below"] else (worst - limit) / abs(limit)


def read_meta(out: Path, runs: list[int]) -> list[dict]:
    """Each run's ``run-K.json`` (commit, seed, exit, wall time); runs of an older hunt without one are left out."""
    metas = []
    for k in runs:
        path = out / f"run-{k}.json"
        with contextlib.suppress(OSError, json.JSONDecodeError):
            metas.append(json.loads(path.read_text()))
    return metas


def report(tests, figures, runs: int, markdown: bool, metas: list[dict] | None = None) -> str:
    out: list[str] = []
    bar = "|" if markdown else " "
    failing = {n: t for n, t in tests.items() if t["failed"]}
    total_failures = sum(t["failed"] for t in tests.values())
    out.append(
        f"{len(tests)} tests, {runs} runs: {total_failures} failures in {len(failing)} tests"
        + ("" if not failing else ": " + ", ".join(sorted(failing)))
    )
    by_commit: dict[str, list[int]] = defaultdict(list)
    for m in metas or []:
        by_commit[m.get("commit", "unknown")].append(m["run"])
    for c, ks in sorted(by_commit.items()):
        walls = [m["wall_s"] for m in metas or [] if m.get("commit", "unknown") == c]
        out.append(f"commit {c}: runs {', '.join(map(str, sorted(ks)))} (wall {min(walls):.0f}-{max(walls):.0f} s)")
    out.append("")
    head = ["test", "passed", "failed", "wall s (median, max)"]
    if markdown:
        out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for node in sorted(tests):
        t = tests[node]
        times = t["times"] or [0.0]
        row = [node, str(t["passed"]), str(t["failed"]), f"{statistics.median(times):.1f}, {max(times):.1f}"]
        out.append((f"{bar} " + f" {bar} ".join(row) + f" {bar}") if markdown else "  ".join(row))
        for why in t["why"]:
            out.append(f"{bar}   {why}" if markdown else f"    {why}")
    if figures:
        out += ["", "Figures the tests assert (record_figure):", ""]
        head = ["test", "figure", "runs", "min", "median", "max", "limit", "worst's margin"]
        if markdown:
            out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for (node, name), e in sorted(figures.items()):
            v = e["values"]
            op = "<" if e["below"] else ">"
            row = [
                node.split("::")[-1][:60],
                name,
                str(len(v)),
                f"{min(v):.4g}",
                f"{statistics.median(v):.4g}",
                f"{max(v):.4g}",
                f"{op} {e['limit']:g} {e['unit']}".strip(),
                f"{100 * margin(e):.0f} %",
            ]
            out.append((f"{bar} " + f" {bar} ".join(row) + f" {bar}") if markdown else "  ".join(row))
    return "\n".join(out)


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("tests", nargs="*", help="pytest paths or node ids (default: -m e2e tests)")
    ap.add_argument("--runs", type=int, default=20, help="how many times to run the selection")
    ap.add_argument("--parallel", type=int, default=1, help="runs at a time (2: two suites side by side)")
    ap.add_argument("--load", type=int, default=0, help="extra processes spinning on the CPU meanwhile")
    ap.add_argument("--jobs", default=None, help="pytest-xdist workers of each run (default: the suite's -n auto)")
    ap.add_argument("-k", default=None, help="pytest's -k expression")
    ap.add_argument("--seeds", action="store_true", help="run k flies with simulator seed FIRST_SEED + k")
    ap.add_argument("--first-seed", type=int, default=1, help="the seed of run 0 with --seeds")
    ap.add_argument("--out", type=Path, default=None, help="keep each run's JUnit XML and figures here")
    ap.add_argument("--markdown", action="store_true", help="print the tables as Markdown")
    ap.add_argument("--report", type=Path, default=None, help="run nothing: the tables of a kept --out DIR")
    args = ap.parse_args()
    if args.report is not None:
        ks = run_indices(args.report)
        tables = report(
            read_results(args.report, ks),
            read_figures(args.report, ks),
            len(ks),
            args.markdown,
            read_meta(args.report, ks),
        )
        print(tables)
        return 0
    out = args.out or Path(tempfile.mkdtemp(prefix="flake-hunt-"))
    out.mkdir(parents=True, exist_ok=True)
    args.commit = commit()
    before = run_indices(out)
    first = before[-1] + 1 if before else 0
    new = list(range(first, first + args.runs))
    import multiprocessing

    spinners = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(args.load)]
    for p in spinners:
        p.start()
    t0 = time.monotonic()
    try:
        with ThreadPoolExecutor(max(1, args.parallel)) as pool:
            futures = [pool.submit(run_once, k, args, out) for k in new]
            for k, fut in zip(new, futures):
                status, wall, summary = fut.result()
                print(f"run {k}: exit {status} in {wall:.0f} s: {summary}", file=sys.stderr, flush=True)
    finally:
        for p in spinners:
            p.terminate()
    print(f"{args.runs} runs, {args.parallel} at a time, {args.load} load processes: {time.monotonic() - t0:.0f} s")
    print(f"(JUnit XML and figures in {out}; runs {new[0]}-{new[-1]} of commit {args.commit})")
    ks = run_indices(out)
    tests, figures = read_results(out, ks), read_figures(out, ks)
    print(report(tests, figures, len(ks), args.markdown, read_meta(out, ks)))
    return 1 if any(t["failed"] for t in tests.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
