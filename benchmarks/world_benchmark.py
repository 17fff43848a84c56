"""Benchmark: real-time factor of one simulated world with 1, 2, 4 ... hovering vehicles (``sitl --count N``).

For each count N it starts ``sitl --count N`` and N flight controllers (instances I..I+N-1, lockstep:
the world steps when every flight controller has answered), takes every vehicle off to 3 m, lets them
hover ``--hover`` simulated seconds and measures the real-time factor (RTF: simulated seconds per wall
second) of the hover.  Each vehicle advances at the world's RTF, so "per vehicle" is the world's RTF and
the machine's total is N times it (vehicle-seconds simulated per wall second).  The flight controllers
are N Python processes beside the simulator: on a machine with fewer cores than N + 1 they share them.

It also times the simulator's physics alone, in-process (``sitl.simulation.World.step`` plus each
vehicle's sensor models, no sockets, no flight controller): microseconds per lockstep period and the
RTF that would leave (the quickest of three blocks of 4 simulated seconds).

Usage: ``python benchmarks/world_benchmark.py [-i I] [--counts 1 2 4] [--hover S]``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from mavsim_core.constants import LOCKSTEP_DT_S

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher.multi_stack import MultiStack  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 3.0
PHYSICS_PERIODS = 1000  # 4 simulated seconds per block
PHYSICS_BLOCKS = 3


def physics_us_per_period(vehicle: str, count: int) -> float:
    """Wall microseconds per lockstep period of a world of ``count`` hovering vehicles, physics and sensors only."""
    from params.vehicle import load_vehicle
    from sitl.simulation import VehicleView, World, spread

    spec = load_vehicle(vehicle)
    world = World(spread(spec, count), (47.397742, 8.545594, 488.0), seed=1)
    views = [VehicleView(world, k) for k in range(count)]
    hover = [np.full(len(spec.rotors), spec.hover_speed_rad_s / spec.max_speed_rad_s)] * count
    best = float("inf")
    for _ in range(PHYSICS_BLOCKS):  # the quickest block: the least disturbed by whatever else runs
        t0 = time.perf_counter()
        for _ in range(PHYSICS_PERIODS):
            for v in views:
                t = v.sensor_truth()
                v.sensors.imu(t.specific_force_frd_m_s2, t.rate_frd_rad_s, t.r_ned_frd, t.pos_ned_m, dt_s=LOCKSTEP_DT_S)
            world.step(hover)
        best = min(best, (time.perf_counter() - t0) / PHYSICS_PERIODS * 1e6)
    return best


def wait_all(stack: MultiStack, clients: list[VehicleClient], predicate, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        stack.check_alive()
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out waiting for {what}")
        for c in clients:
            c.pump(0.01)


def hover_rtf(args, count: int, progress: Progress) -> float:
    """The world's RTF while its ``count`` vehicles hover ``args.hover`` simulated seconds."""
    with MultiStack(args.instance, speed="max", vehicle=args.vehicle, count=count, flight_logs=False) as stack:
        clients = [VehicleClient(stack.api_url_of(k), timeout_s=60, idle=stack.check_alive) for k in range(count)]
        try:
            progress.watch(clients[0])
            wait_all(stack, clients, lambda: all(c.prearm_ok() and c.home() for c in clients), 180, "ready to arm")
            progress.done(phase="take-off")
            for c in clients:
                c.arm().check()
                c.takeoff(c.home().alt_amsl_m + ALT_M).check()
            wait_all(stack, clients, lambda: all(c.takeoff_done(ALT_M) for c in clients), 300, "every take-off")
            progress.done(phase=f"hover {args.hover:g} s")
            wall0, sim0 = time.monotonic(), clients[0].sim_time_s()
            wait_all(stack, clients, lambda: clients[0].sim_time_s() - sim0 >= args.hover, 600, "the hover")
            rtf = (clients[0].sim_time_s() - sim0) / (time.monotonic() - wall0)
            progress.done(phase="stopping")
            progress.watch(None)
        finally:
            for c in clients:
                c.close()
    return rtf


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 13)
    ap.add_argument("--counts", type=int, nargs="+", default=[1, 2, 4], help="vehicles per world, one run each")
    ap.add_argument("--hover", type=float, default=20.0, help="hover duration, simulated seconds")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    args = ap.parse_args(argv)
    rows = []
    with Progress(3 * len(args.counts), "phase") as progress:
        for n in args.counts:
            progress.label(f"world of {n}")
            progress.phase("physics alone")
            us = physics_us_per_period(args.vehicle, n)
            progress.phase("starting the stack")
            rows.append((n, us, hover_rtf(args, n, progress)))
    print(f"vehicle {args.vehicle}, hover {args.hover:g} s at {ALT_M:g} m, lockstep at --speed max")
    print("vehicles | world RTF (= per vehicle) | vehicle-s per wall s | physics alone: us/period, RTF, vehicle-s/s")
    for n, us, rtf in rows:
        phys_rtf = LOCKSTEP_DT_S * 1e6 / us
        print(f"{n:8d} | {rtf:25.2f} | {n * rtf:20.2f} | {us:8.0f} us, {phys_rtf:6.1f}x, {phys_rtf * n:6.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
