"""Benchmark: where the two processes of the lockstep stack spend their time (cProfile), per simulated second.

It flies one flight (no camera: take-off to 5 m, a hover of ``--hover`` simulated seconds, the demo's
10 m square, landing; ``--speed max``, flight logs on, as the flight benchmark flies it) and prints:

- CPU seconds per simulated second of each process (user + system, ``/proc/PID/stat``, from ready-to-arm
  to landed): what a loaded machine does not distort, and what the wall-clock speed on a quiet 2-core
  machine follows; the wall real-time factor (simulated / wall seconds) of the same window;
- per process, the top ``--top`` functions by own time and by cumulative time, in CPU milliseconds per
  simulated second (and calls per simulated second), from one more flight with both processes under
  cProfile with a CPU clock (``benchmarks/_cpu_profile.py``: time blocked in ``recv`` counts nothing), over
  the same window.  The profiler's overhead inflates those figures, most for small functions called often;
  the CPU figures above come from flights without it.

``--baseline DIR`` flies the same flights with another checkout (``PYTHONPATH=DIR``, e.g. a git worktree of
an older commit) in the same run, alternating with this one, and prints the figures before and after side by
side (``--checkout DIR``: another "after" than this checkout).  Each flight runs in a child process of its
checkout; ``--repeat N`` flies N plain flights of each.

Usage: ``python benchmarks/profile_lockstep.py [-i N] [--hover S] [--baseline DIR] [--repeat N] [--top N]``
"""

from __future__ import annotations

import argparse
import json
import os
import pstats
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
ROOT = HERE.parents[1]
ALT_M = 5.0
SIDE_M = 10.0
PROCESSES = ("sitl", "autopilot")
CLK_TCK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process so far (``/proc/PID/stat`` fields 14 and 15)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


# ------------------------------------------------------------------ the flight (in a child, one checkout)


def fly(instance: int, hover_s: float, vehicle: str, profile_dir: str | None) -> dict:
    """One flight of the checkout first on ``sys.path``; its CPU and time figures (profiles in ``profile_dir``)."""
    from gcs.client import VehicleClient
    from gcs.launcher import Stack

    modules = {}
    if profile_dir:  # each process under benchmarks/_cpu_profile.py, profiling from SIGUSR1 to SIGUSR2
        modules = {f"{p}_module": f"_cpu_profile {profile_dir}/{p}.prof {p}" for p in PROCESSES}
    logs = tempfile.TemporaryDirectory(prefix="profile-lockstep-logs-")  # the stack's logs, gone after the flight
    with logs, Stack(instance=instance, speed="max", vehicle=vehicle, log_dir=logs.name, **modules) as stack:
        client = VehicleClient(stack.api_url, timeout_s=60, idle=stack.check_alive)
        client.wait_until(client.prearm_ok, 180, "ready to arm")
        pids = {name: stack.procs[name].pid for name in PROCESSES}
        cpu0 = {name: cpu_s(pid) for name, pid in pids.items()}
        _signal(pids, signal.SIGUSR1, profile_dir)
        wall0, sim0 = time.monotonic(), client.sim_time_s()
        client.arm().check()
        client.takeoff(client.home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M), 120, "take-off to 5 m")
        client.wait_sim_time(hover_s)
        for n, e in ((SIDE_M, 0.0), (SIDE_M, SIDE_M), (0.0, SIDE_M), (0.0, 0.0)):
            client.goto_ned(n, e, -ALT_M).check()
            client.wait_until(lambda: client.arrived(n, e, 0.3, 0.3), 120, f"corner {n:.0f},{e:.0f}")
        client.land().check()
        client.wait_until(client.landed_and_disarmed, 180, "landed and disarmed")
        cpu1 = {name: cpu_s(pid) for name, pid in pids.items()}
        wall1, sim1 = time.monotonic(), client.sim_time_s()
        _signal(pids, signal.SIGUSR2, profile_dir)
        client.close()
    sim_s = sim1 - sim0
    return {
        "sim_s": sim_s,
        "rtf": sim_s / (wall1 - wall0),
        "cpu_per_sim_s": {name: (cpu1[name] - cpu0[name]) / sim_s for name in PROCESSES},
    }


def _signal(pids: dict[str, int], sig: int, profile_dir: str | None) -> None:
    """Start (SIGUSR1) or stop (SIGUSR2) the profilers of a profiled flight."""
    if profile_dir:
        for pid in pids.values():
            os.kill(pid, sig)


def run_flight(root: Path, args, profile_dir: str | None) -> dict:
    """One flight of checkout ``root``, in a child process whose ``sys.path`` starts with it."""
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        out = f.name
    cmd = [sys.executable, str(HERE), "--worker", str(root), "--out", out, "-i", str(args.instance)]
    cmd += ["--hover", str(args.hover), "--vehicle", args.vehicle]
    if profile_dir:
        cmd += ["--profile-dir", profile_dir]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join((str(root), str(HERE.parent))))  # + _cpu_profile
    try:
        subprocess.run(cmd, env=env, check=True, cwd=root, stdout=subprocess.DEVNULL)
        return json.loads(Path(out).read_text())
    finally:
        Path(out).unlink(missing_ok=True)


# ------------------------------------------------------------------ the profiles


def _label(key: tuple[str, int, str], root: str) -> str:
    """``path/in/checkout.py:function`` (line numbers differ between checkouts), or the builtin's name."""
    file, _line, func = key
    if file == "~":
        return func
    for prefix in (root.rstrip("/") + "/", sys.prefix + "/", sys.base_prefix + "/"):
        if file.startswith(prefix):
            file = file[len(prefix) :]
            break
    file = file.split("site-packages/", 1)[-1]
    return f"{file}:{func}"


def load_profile(path: Path, root: Path, sim_s: float) -> dict[str, tuple[float, float, int]]:
    """label -> (own ms, cumulative ms, calls), per simulated second."""
    out: dict[str, tuple[float, float, int]] = {}
    for key, (_cc, nc, tt, ct, _callers) in pstats.Stats(str(path)).stats.items():
        label = _label(key, str(root))
        own, cum, calls = out.get(label, (0.0, 0.0, 0))
        out[label] = (own + tt * 1e3 / sim_s, max(cum, ct * 1e3 / sim_s), calls + round(nc / sim_s))
    return out


def print_table(title: str, runs: dict[str, dict], column: int, top: int) -> None:
    """The ``top`` entries of each run by ``column`` (0: own, 1: cumulative), the runs side by side."""
    names = list(runs)
    keys: list[str] = []
    for prof in runs.values():
        for label, _ in sorted(prof.items(), key=lambda kv: -kv[1][column])[:top]:
            if label not in keys:
                keys.append(label)
    keys.sort(key=lambda k: -max(p.get(k, (0.0, 0.0, 0))[column] for p in runs.values()))
    print(f"\n{title} (ms per simulated second; calls per simulated second)")
    print("".join(f"{n:>22}" for n in names) + "  function")
    for k in keys:
        cells = []
        for n in names:
            v = runs[n].get(k)
            cells.append(f"{v[column]:>12.1f} {v[2]:>8d} " if v else f"{'-':>12} {'':>8} ")
        print(" ".join(cells) + " " + k)


def print_cpu(results: dict[str, list[dict]]) -> None:
    print("CPU seconds per simulated second (median of the plain flights), wall real-time factor")
    for name, flights in results.items():
        med = lambda xs: sorted(xs)[len(xs) // 2]  # noqa: E731
        cpu = {p: med([f["cpu_per_sim_s"][p] for f in flights]) for p in PROCESSES}
        rtfs = ", ".join(f"{f['rtf']:.1f}x" for f in flights)
        total = sum(cpu.values())
        print(
            f"  {name:>8}: sitl {cpu['sitl']:.4f}  autopilot {cpu['autopilot']:.4f}  both {total:.4f} "
            f"(-> at most {1 / max(cpu.values()):.0f}x on 2 idle cores, {1 / total:.0f}x on one); RTF {rtfs} "
            f"over {flights[0]['sim_s']:.0f} simulated s"
        )


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(HERE.parent))
    from _cli import add_instance, parser

    ap = parser(__doc__, progress=False)
    add_instance(ap, 24)
    ap.add_argument("--hover", type=float, default=20.0, help="hover duration, simulated seconds")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    ap.add_argument("--baseline", type=Path, help="another checkout to fly the same flights with (before)")
    ap.add_argument("--checkout", type=Path, help="the checkout to profile (after); default: this one")
    ap.add_argument("--repeat", type=int, default=1, help="plain (unprofiled) flights per checkout")
    ap.add_argument("--top", type=int, default=15, help="entries per table")
    ap.add_argument("--no-profile", action="store_true", help="CPU figures only: no profiled flight")
    ap.add_argument("--keep", type=Path, help="keep the profiles (NAME/sitl.prof, NAME/autopilot.prof) here")
    ap.add_argument("--worker", type=Path, help=argparse.SUPPRESS)  # a child: one flight of this checkout
    ap.add_argument("--out", help=argparse.SUPPRESS)  # the child's figures (JSON)
    ap.add_argument("--profile-dir", help=argparse.SUPPRESS)  # the child's profiles
    args = ap.parse_args(argv)
    if args.worker is not None:
        Path(args.out).write_text(json.dumps(fly(args.instance, args.hover, args.vehicle, args.profile_dir)))
        return 0
    after = (args.checkout or ROOT).resolve()
    roots = {"before": args.baseline.resolve(), "after": after} if args.baseline else {"this": after}
    results: dict[str, list[dict]] = {name: [] for name in roots}
    for k in range(args.repeat):
        for name, root in roots.items():
            print(f"[profile] plain flight {k + 1}/{args.repeat}: {name} ({root})", file=sys.stderr, flush=True)
            results[name].append(run_flight(root, args, None))
    if args.repeat > 0:
        print_cpu(results)
    if args.no_profile:
        return 0
    with tempfile.TemporaryDirectory(prefix="profile-lockstep-") as tmp:
        profiles: dict[str, dict[str, dict]] = {p: {} for p in PROCESSES}
        for name, root in roots.items():
            print(f"[profile] profiled flight: {name} ({root})", file=sys.stderr, flush=True)
            d = (args.keep.resolve() if args.keep else Path(tmp)) / name
            d.mkdir(parents=True, exist_ok=True)
            r = run_flight(root, args, str(d))
            for p in PROCESSES:
                profiles[p][name] = load_profile(d / f"{p}.prof", root, r["sim_s"])
    for p in PROCESSES:
        print_table(f"{p}: top {args.top} by own time", profiles[p], 0, args.top)
        print_table(f"{p}: top {args.top} by cumulative time", profiles[p], 1, args.top)
    return 0


if __name__ == "__main__":
    sys.exit(main())
