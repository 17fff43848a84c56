"""Benchmark: mission transfer speed and the cross-track error of a mission flown at cruise speed.

Starts the simulator and the flight controller (``--speed max``, lockstep), then:

1. uploads and downloads missions of 100 and 500 waypoints over loopback UDP with the ground
   station's own protocol client (``gcs/mission_transfer.py``), wall time of each (goal: under
   0.5 s for 500 items);
2. uploads a 4-leg mission (take-off, a square of SIDE_M metres at MPC_XY_CRUISE, land), flies it
   and compares the ground truth (the simulator's own UDP port) with the legs: the horizontal
   distance from the true position to the nearest leg, RMS and maximum over the legs' straight
   parts and corners, and each corner's closest approach.

The flight controller answers a request within one 4 ms lockstep step, so at ``--speed 1`` an item
takes 4 ms.  A progress bar (stderr) counts the phases (ready, the two transfers, the mission's
start, each of its items, the landing) and shows the simulated seconds flown.

Usage: ``python benchmarks/mission_benchmark.py [-i N] [--side M] [--vehicle NAME] [--speed S]
[--no-flight]``
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.mission_transfer import download, upload  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import mission_items as mi  # noqa: E402
from mavsim_core import ports  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

HOME = (47.397742, 8.545594)  # the simulator's default home
ALT_M = 8.0
TRANSFER_ITEMS = (100, 500)
FLIGHT_PHASES = 7  # the mission started, items 1-5 current in turn, landed


def latlon_e7(north_m: float, east_m: float) -> tuple[int, int]:
    r = 6378137.0
    lat = HOME[0] + math.degrees(north_m / r)
    lon = HOME[1] + math.degrees(east_m / (r * math.cos(math.radians(HOME[0]))))
    return round(lat * 1e7), round(lon * 1e7)


def item(seq: int, command: int, north: float, east: float, alt: float) -> mi.MissionItem:
    x, y = latlon_e7(north, east)
    return mi.MissionItem(seq, mi.FRAME_GLOBAL_RELATIVE_ALT_INT, command, 0, 0, 0, math.nan, x, y, alt)


def transfer_times(client: VehicleClient, n: int) -> tuple[float, float]:
    items = [item(k, mi.NAV_WAYPOINT, 0.5 * (k % 40), 0.5 * (k // 40), ALT_M) for k in range(n)]
    t0 = time.monotonic()
    upload(client, items, mi.MISSION)
    t1 = time.monotonic()
    back = download(client, mi.MISSION)
    t2 = time.monotonic()
    assert [(b.x, b.y) for b in back] == [(i.x, i.y) for i in items], "download differs from upload"
    return t1 - t0, t2 - t1


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-9), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def fly_square(client: VehicleClient, truth: SimClient, side: float, progress: Progress) -> dict:
    """Upload and fly the square mission; the cross-track figures of its legs against the truth."""
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    items = [item(0, mi.NAV_TAKEOFF, 0, 0, ALT_M)]
    items += [item(k + 1, mi.NAV_WAYPOINT, n, e, ALT_M) for k, (n, e) in enumerate(corners[1:])]
    items.append(item(len(items), mi.NAV_LAND, 0, 0, 0))
    upload(client, items, mi.MISSION)
    client.wait_until(lambda: client.prearm_ok() and not client.armed(), 90, "ready to arm")
    client.set_mode("MISSION")
    client.arm()
    progress.done(phase="take-off (item 0)")
    current = {}

    def on(msg) -> None:
        if msg.get_type() == "MISSION_CURRENT":
            if msg.seq not in current and 1 <= msg.seq < len(items):
                progress.done(phase=f"item {msg.seq} of {len(items) - 1}")
            current[msg.seq] = current.get(msg.seq) or truth.latest().time_ms

    client.add_listener(on)
    client.wait_until(lambda: not client.armed() and len(current) > 3, 300, "the mission's landing")
    client.remove_listener(on)
    progress.finish("landed")
    # the legs: from arriving at the first corner (current item 2) to the last corner (item 5 done)
    start, end = current[2], current.get(6, truth.latest().time_ms)
    samples = [s for s in truth.since(start) if s.time_ms <= end]
    pts = np.array([s.pos_ned_m[:2] for s in samples])
    legs = [(np.array(a), np.array(b)) for a, b in zip(corners[:-1], corners[1:])]
    xtrack = np.array([min(segment_distance(p, a, b) for a, b in legs) for p in pts])
    speed = np.array([math.hypot(*s.vel_ned_m_s[:2]) for s in samples])
    closest = [min(float(np.linalg.norm(pts - np.array(c), axis=1).min()), 99.0) for c in corners[1:]]
    return {
        "rms": float(np.sqrt(np.mean(xtrack**2))), "max": float(xtrack.max()), "closest": closest,
        "mean_speed": float(speed.mean()), "duration_s": (end - start) / 1000.0,
    }  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 26)
    ap.add_argument("--side", type=float, default=30.0, help="side of the square mission, m")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    ap.add_argument("--speed", default="max", help="simulator speed: max or N x real time")
    ap.add_argument("--no-flight", action="store_true", help="only the transfer times")
    args = ap.parse_args(argv)
    progress = Progress(1 + len(TRANSFER_ITEMS) + (0 if args.no_flight else FLIGHT_PHASES), "phase", "mission")
    progress.phase("starting the stack")
    with progress, SimClient(ports.sim_component_port(args.instance)) as truth:
        with Stack(instance=args.instance, speed=args.speed, vehicle=args.vehicle, flight_logs=False) as stack:
            with VehicleClient(stack.gcs_url, timeout_s=60, idle=progress.idle(stack.check_alive)) as c:
                progress.watch(c)
                c.wait_until(c.prearm_ok, 90, "ready to arm")
                for n in TRANSFER_ITEMS:
                    progress.done(phase=f"{n} items up and down")
                    up, down = transfer_times(c, n)
                    progress.say(f"{n:4d} items: upload {up:.3f} s, download {down:.3f} s (speed {args.speed})")
                if args.no_flight:
                    progress.done(phase="done")
                    return 0
                progress.done(phase="mission upload, arming")
                r = fly_square(c, truth, args.side, progress)
                progress.watch(None)
    print(
        f"4-leg mission, {args.side:g} m square at cruise speed ({args.vehicle}): "
        f"cross-track RMS {r['rms']:.3f} m, "
        f"max {r['max']:.3f} m; mean ground speed {r['mean_speed']:.2f} m/s over {r['duration_s']:.1f} s"
    )
    print("closest approach to each corner: " + ", ".join(f"{d:.2f} m" for d in r["closest"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
