"""Benchmark: hover accuracy and real-time factor of the two-process stack.

Starts the simulator and the flight controller (``--speed max``, lockstep,
telemetry on), takes off to 5 m, holds 30 simulated seconds and compares the
ground truth (the simulator's LOCAL_POSITION_NED on UDP 14740+instance, float
metres from the start point) with the commanded point (5 m above where the
vehicle was armed).  Then it flies the demo square and lands.  It prints:

- hover error, RMS, horizontal and vertical (truth against the commanded point);
- the estimator's position error against truth during the hover;
- the real-time factor (simulated seconds per wall second) of the hover and of
  the whole flight;
- the landing error from the take-off point;
- the size of each flight log (the flight controller's ``.ulg`` and ``.tlog``, the simulator's
  ``.truth.npy``) per simulated minute, the minutes those of the truth log (arming to 1 s after disarming).

A progress bar (stderr) counts the flight's phases (ready, take-off, settle, hover, four corners,
landing) and shows the simulated seconds flown.  ``--param SDLOG_MODE=-1``: the flight without its
ULog, to measure what logging costs.

Usage: ``python benchmarks/flight_benchmark.py [-i N] [--hover S] [--vehicle NAME] [--param NAME=VALUE]``
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from pymavlink import mavutil

from mavsim_core import ports

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 5.0
SIDE_M = 10.0
PHASES = 9  # ready, take-off, settle, hover, four corners, landed


class Truth:
    """The simulator's ground truth, read from its UDP port."""

    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=254)
        self.pos_ned = None
        self.time_s = 0.0

    def pump(self) -> None:
        while True:
            m = self.conn.recv_match(type="LOCAL_POSITION_NED", blocking=False)
            if m is None:
                return
            self.pos_ned = np.array([m.x, m.y, m.z])
            self.time_s = m.time_boot_ms / 1000.0


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a * a))) if len(a) else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 20)
    ap.add_argument("--hover", type=float, default=30.0, help="hover duration, simulated seconds")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    ap.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a flight-controller parameter for the flight (autopilot --params), repeatable",
    )
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="flight-benchmark-") as tmp, Progress(PHASES, "phase") as progress:
        extra: list[str] = []
        if args.param:
            params_file = Path(tmp) / "benchmark.params"
            params_file.write_text("".join(p.replace("=", " ", 1) + "\n" for p in args.param))  # MAVProxy's NAME VALUE
            extra = ["--params", str(params_file)]
        progress.label(f"{args.vehicle} flight")
        progress.phase("starting the stack")
        return fly(args, extra, progress)


def fly(args, extra: list[str], progress: Progress) -> int:
    """The flight and its figures (printed)."""
    with Stack(instance=args.instance, speed="max", vehicle=args.vehicle, extra_autopilot_args=extra) as stack:
        truth = Truth(ports.sim_component_port(args.instance))
        idle = progress.idle(lambda: (truth.pump(), stack.check_alive()))
        client = VehicleClient(stack.api_url, timeout_s=60, idle=idle)
        progress.watch(client)
        client.wait_until(client.prearm_ok, 120, "ready to arm")
        progress.done(phase="take-off")
        truth.pump()
        start_truth = truth.pos_ned.copy()
        wall_flight0, sim_flight0 = time.monotonic(), client.sim_time_s()
        client.arm().check()
        client.takeoff(client.home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M), 120, "take-off to 5 m")
        progress.done(phase="settle")
        client.wait_sim_time(5.0)  # settle
        progress.done(phase=f"hover {args.hover:g} s")
        target = start_truth + np.array([0.0, 0.0, -ALT_M])
        samples, est_err = [], []
        wall0, sim0 = time.monotonic(), truth.time_s
        last = None
        while truth.time_s - sim0 < args.hover:
            client.pump(0.05)
            truth.pump()
            if truth.time_s != last and truth.pos_ned is not None:
                last = truth.time_s
                samples.append(truth.pos_ned - target)
                lp = client.local_position_ned()
                home = client.latest("HOME_POSITION")
                if lp is not None and home is not None:
                    est_rel = np.array(lp) - np.array([home.x, home.y, home.z])
                    est_err.append(est_rel - (truth.pos_ned - start_truth))
        hover_rtf = (truth.time_s - sim0) / (time.monotonic() - wall0)
        err = np.array(samples)
        eerr = np.array(est_err) if est_err else np.zeros((0, 3))

        for k, (n, e) in enumerate(((SIDE_M, 0.0), (SIDE_M, SIDE_M), (0.0, SIDE_M), (0.0, 0.0))):
            progress.done(phase=f"corner {k + 1} of 4")
            client.goto_ned(n, e, -ALT_M).check()
            client.wait_until(lambda: client.arrived(n, e, 0.3, 0.3), 120, f"corner {n:.0f},{e:.0f}")
        progress.done(phase="landing")
        client.land().check()
        client.wait_until(client.landed_and_disarmed, 180, "landed and disarmed")
        progress.done(phase="landed")
        truth.pump()
        flight_rtf = (client.sim_time_s() - sim_flight0) / (time.monotonic() - wall_flight0)
        land_err = float(np.hypot(*(truth.pos_ned - start_truth)[:2]))
        progress.watch(None)
        client.close()
    progress.close()

    print(f"vehicle {args.vehicle}, hover {args.hover:.0f} s at {ALT_M:.0f} m, {len(err)} truth samples (50 Hz)")
    print(
        f"hover error vs truth, RMS: horizontal {rms(np.hypot(err[:, 0], err[:, 1])):.3f} m, "
        f"vertical {rms(err[:, 2]):.3f} m (max horizontal {np.hypot(err[:, 0], err[:, 1]).max():.3f} m)"
    )
    if len(eerr):
        print(
            f"estimator position error vs truth, RMS: horizontal {rms(np.hypot(eerr[:, 0], eerr[:, 1])):.3f} m, "
            f"vertical {rms(eerr[:, 2]):.3f} m"
        )
    print(
        f"real-time factor: hover {hover_rtf:.1f}x, whole flight (take-off, hover, square, landing) {flight_rtf:.1f}x"
    )
    print(f"landing error from the take-off point: {land_err:.2f} m")
    print(log_sizes(Path(stack.log_dir)))
    return 0


def log_sizes(log_dir: Path) -> str:
    """The flight's log files, in kB per simulated minute of its truth log."""
    truth = sorted(log_dir.glob("*.truth.npy"))
    if not truth:
        return f"flight logs: no truth log in {log_dir}"
    t = np.load(truth[-1], mmap_mode="r")["time_us"]
    minutes = (int(t[-1]) - int(t[0])) / 60e6
    sizes = [(sfx, sum(f.stat().st_size for f in log_dir.glob("*" + sfx))) for sfx in (".ulg", ".tlog", ".truth.npy")]
    total = sum(size for _, size in sizes)
    parts = ", ".join(f"{sfx} {size / 1e3 / minutes:.0f}" for sfx, size in sizes + [("total", total)])
    return f"flight logs, kB per simulated minute ({minutes * 60:.0f} s logged): {parts}"


if __name__ == "__main__":
    sys.exit(main())
