"""Benchmark: where a camera landing's lockstep periods go, and what each phase of the flight costs in CPU.

Flies ``--runs`` precision landings on the ground vehicle (the landing campaign's flight,
``gcs/launcher/landing_run.py``: take-off, the meeting point, NAV_LAND onto the deck driving its circle, five
seconds on the deck), one at a time, at full speed, and prints:

- per phase of the flight (ready to arm, take-off, to the meeting point, the landing from NAV_LAND to the motors'
  cut, the five seconds on the deck): simulated seconds, wall seconds, the real-time factor, and the CPU seconds
  per simulated second of the simulator, the flight controller and the camera's process (``/proc``);
- over the landing phase, each 4 ms lockstep period split into its parts, from per-period time stamps of both
  processes on one clock (``benchmarks/_trace_wrap.py``): the simulator's physics and sensors, the flight
  controller's step, the time each waited for the other to be *scheduled* after its message went out (its "wake
  latency": spinning on the socket, waking from it, or waiting for a core), and the time one finished late its work
  of the period before (the flight controller's 50 Hz outer loop, the simulator's truth port);
- the wake latencies again, split by whether the camera's process was working on a frame at that moment.

The time stamps cost a few microseconds a period: compare figures within one run.

Usage: ``python benchmarks/lockstep_trace.py [--runs N] [-i N]``
"""

from __future__ import annotations

import math
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))
CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process so far (0 if it is gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            return [int(c) for c in f.read().split()]
    except OSError:
        return []


def fly(instance: int, seed: int, prefix: str) -> list[tuple[str, float, float, float, float, float]]:
    """One landing; its phases as (name, simulated s, wall s, CPU s of the simulator, flight controller, camera)."""
    from gcs.client import VehicleClient
    from gcs.launcher import Stack
    from gcs.launcher.landing_run import LandingSetup, Pose2, deck_model_params, fly_landing
    from gcs.sim_client import SimClient
    from mavsim_core import ports

    setup = LandingSetup(
        vehicle="quad_x", path="circle", speed_m_s=2.0, windy=False, seed=seed, ugv_start=Pose2(4.0, 0.0, 0.5),
        camera="gimbal", pad="nested", fc_params=deck_model_params(),
    )  # fmt: skip
    modules = {
        "sitl_module": f"_trace_wrap {prefix} sitl sitl",
        "autopilot_module": f"_trace_wrap {prefix} autopilot autopilot",
    }
    phases: list[tuple[str, float, float, float, float, float]] = []
    with Stack(instance=instance, speed="max", seed=seed, extra_sitl_args=setup.sim_args(), flight_logs=False,
               **modules) as stack:  # fmt: skip
        sitl, fc = stack.procs["sitl"].pid, stack.procs["autopilot"].pid
        with SimClient(ports.sim_component_port(instance)) as truth:
            client = VehicleClient(stack.api_url, timeout_s=60)

            def snapshot() -> tuple[float, float, float, float, float]:
                camera = sum(cpu_s(c) for c in children(sitl))
                return time.monotonic(), client.sim_time_s() or 0.0, cpu_s(sitl), cpu_s(fc), camera

            last = [snapshot(), "ready to arm"]
            # What fly_landing says as each phase begins: the phase that begins (the one before it ends).
            names = {"set for": "take-off", "flying to": "to the meeting point", "UGV driving": "landing"}

            def phase_ends(next_name: str) -> None:
                now = snapshot()
                (w0, s0, a0, b0, c0), name = last[0], last[1]
                if now[1] > s0:
                    phases.append((name, now[1] - s0, now[0] - w0, now[2] - a0, now[3] - b0, now[4] - c0))
                last[0], last[1] = now, next_name

            def say(text: str) -> None:
                for start, name in names.items():
                    if text.startswith(start):
                        phase_ends(name)
                if text == "precision landing":  # (right after "UGV driving": the landing phase's trace starts)
                    for pid in (sitl, fc):
                        os.kill(pid, signal.SIGUSR1)

            def on_message(msg) -> None:
                if msg.get_type() == "STATUSTEXT" and msg.text.startswith("Disarmed") and last[1] == "landing":
                    for pid in (sitl, fc):
                        os.kill(pid, signal.SIGUSR2)
                    phase_ends("on the deck")

            client.add_listener(on_message)
            result = fly_landing(client, truth, setup, say=say)
            phase_ends("")
            if not result.success:
                print(f"  (seed {seed}: {result.reason or 'not landed'})", file=sys.stderr)
    return phases


def periods(prefix: str) -> tuple[np.ndarray, np.ndarray]:
    """Each landing period's parts (µs; columns as PARTS) and whether the camera was busy at the FC's and the
    simulator's wake-up."""
    s, f = np.load(prefix + ".sitl.npy"), np.load(prefix + ".autopilot.npy")
    camera = np.load(prefix + ".camera.npy") if Path(prefix + ".camera.npy").exists() else np.zeros((0, 2))

    def ev(a: np.ndarray, code: int) -> np.ndarray:
        return a[a[:, 0] == code, 1]

    act_in, post_done, marks = ev(s, 1), ev(s, 4), ev(s, 3)
    fc_in, fc_out, fc_after = ev(f, 12), ev(f, 13), ev(f, 14)
    starts = np.concatenate([[-math.inf], post_done[:-1]])  # a period of the simulator: after the previous post
    sent = []
    for a, b in zip(starts, post_done):
        inside = marks[(marks > a) & (marks < b)]
        sent.append(inside.min() if len(inside) else b)
    sent_a = np.array(sent)

    def busy(t: float) -> bool:
        i = np.searchsorted(camera[:, 0], t) - 1
        return bool(i >= 0 and camera[i, 1] > t)

    rows, flags = [], []
    for k in range(1, len(sent_a) - 1):
        i = int(np.searchsorted(fc_in, sent_a[k]))
        if i < 1 or i >= min(len(fc_in), len(fc_out), len(fc_after)):
            continue
        a = int(np.searchsorted(act_in, fc_out[i]))
        if a >= len(act_in):
            continue
        fc_ready = max(sent_a[k], fc_after[i - 1])
        sim_ready = max(fc_out[i], post_done[k])
        rows.append((
            sent_a[k + 1] - sent_a[k],
            max(0.0, fc_after[i - 1] - sent_a[k]),
            fc_in[i] - fc_ready,
            fc_out[i] - fc_in[i],
            max(0.0, post_done[k] - fc_out[i]),
            act_in[a] - sim_ready,
            sent_a[k + 1] - act_in[a],
        ))  # fmt: skip
        flags.append((busy(fc_ready), busy(sim_ready)))
    return np.array(rows) * 1e6, np.array(flags, dtype=bool)


PARTS = (
    "period (sensors out to sensors out)",
    "  FC late: its previous period's work",
    "  FC wake latency",
    "  FC step (sensors in to actuators out)",
    "  simulator late: its truth port, logs",
    "  simulator wake latency",
    "  simulator physics and sensors",
)


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(HERE.parent))
    from _cli import add_instance, parser

    ap = parser(__doc__, progress=False)
    add_instance(ap, 26)
    ap.add_argument("--runs", type=int, default=3, help="landings (seeds 3, 4, ...)")
    args = ap.parse_args(argv)
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE.parent), os.environ.get("PYTHONPATH")) if p)
    all_phases: dict[str, list[tuple[float, ...]]] = {}
    all_rows, all_flags = [], []
    with tempfile.TemporaryDirectory(prefix="lockstep-trace-") as tmp:
        for k in range(args.runs):
            prefix = f"{tmp}/run{k}"
            for name, *figures in fly(args.instance, 3 + k, prefix):
                all_phases.setdefault(name, []).append(tuple(figures))
            rows, flags = periods(prefix)
            all_rows.append(rows)
            all_flags.append(flags)
    print(f"{args.runs} landings (circle 2 m at 2 m/s, calm, seeds 3..{2 + args.runs}), one at a time")
    print(f"{'phase':24s} {'sim s':>7s} {'wall s':>7s} {'RTF':>6s}   CPU s per simulated s: simulator, FC, camera")
    total_sim = total_wall = 0.0
    for name, runs in all_phases.items():
        sim, wall, a, b, c = (sum(x) for x in zip(*runs))
        total_sim, total_wall = total_sim + sim, total_wall + wall
        print(f"{name:24s} {sim:7.2f} {wall:7.3f} {sim / wall:5.1f}x   {a / sim:.3f}  {b / sim:.3f}  {c / sim:.3f}")
    print(f"{'whole flight':24s} {total_sim:7.2f} {total_wall:7.3f} {total_sim / total_wall:5.1f}x")
    rows, flags = np.concatenate(all_rows), np.concatenate(all_flags)
    print(f"\nThe landing phase's {len(rows)} periods, microseconds: mean (median, 90th percentile)")
    for j, name in enumerate(PARTS):
        x = rows[:, j]
        print(f"  {name:40s} {x.mean():7.1f} ({np.percentile(x, 50):6.1f}, {np.percentile(x, 90):7.1f})")
    print("Wake latencies by what the camera's process was doing at that moment: mean (median, 90th percentile)")
    for j, (name, col) in enumerate((("FC", 2), ("simulator", 5))):
        for state in (False, True):
            m = flags[:, j] == state
            x = rows[m, col]
            share = 100.0 * m.mean()
            label = f"{name}, camera {'busy' if state else 'idle'} ({share:.0f} % of periods)"
            print(f"  {label:40s} {x.mean():7.1f} ({np.percentile(x, 50):6.1f}, {np.percentile(x, 90):7.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
