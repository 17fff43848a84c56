"""Campaign kind ``mission``: a square mission flown at cruise speed, its cross-track error scored from truth.

One run is one stack (``--speed`` of its cell, lockstep) that:

1. (when a transfer figure is recorded) uploads and downloads missions of 100 and 500 waypoints over
   loopback UDP with the ground station's own protocol client (gcs/mission_transfer.py): wall seconds
   of each (``upload_100_s`` ...); a download that differs from the upload fails the run;
2. (when a flight figure is recorded) uploads a 4-leg mission: take-off to ``ALT_M`` (8 m), a square
   of ``side_m`` metres (North, then East, South, West back to the start) at MPC_XY_CRUISE, land; flies
   it in MISSION mode and compares the truth (the simulator's LOCAL_POSITION_NED, NED metres from the
   start point) with the legs, from reaching the first corner to the touchdown after the last one (the
   truth back within ``TOUCHDOWN_M`` of the start point's height; ``legs_s``, simulated s): the
   horizontal distance to the nearest leg (cross-track; RMS and maximum), the mean ground speed, and
   each corner's closest approach (``corner1_m`` ... ``corner4_m``, the last is the start point).

So a campaign that records only the transfer figures flies nothing, and one that records only flight
figures transfers nothing.  The flight succeeds when every item became current in turn and it landed.

Grid axes: ``vehicle``, ``side_m`` (5-200 m), ``wind`` (calm, or windy: params/scenarios/windy.toml:
5 m/s from the West, 1 m/s turbulence, 2 m/s gusts, from the start), ``speed`` (the simulator's:
``max`` or a real-time factor; the transfer times depend on it, 4 ms per item at 1x).  Randomised:
``sim_seed`` (``sitl --seed``).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from gcs.client import VehicleClient
from gcs.mission_transfer import download, upload
from gcs.sim_client import SimClient
from mavsim_core import mission_items as mi

from .hover_step import sim_args, windy_parameters
from .kinds import Axis, Range, grid_cells, number_in, one_of, vehicle_name
from .plan import Run

HOME = (47.397742, 8.545594)  # the simulator's default home (deg)
ALT_M = 8.0
TRANSFER_ITEMS = (100, 500)
TRANSFER_FIGURES = tuple(f"{d}_{n}_s" for n in TRANSFER_ITEMS for d in ("upload", "download"))
FLIGHT_FIGURES = ("xtrack_rms_m", "xtrack_max_m", "mean_speed_m_s", "legs_s", *(f"corner{k}_m" for k in range(1, 5)))
TOUCHDOWN_M = 0.1  # the touchdown: the truth back within this height (m) of the start point's
READY_S, MISSION_S = 90.0, 300.0  # wall seconds of the waits (safety nets, longer at real-time speed)


def latlon_e7(north_m: float, east_m: float) -> tuple[int, int]:
    """A point ``north_m``, ``east_m`` from :data:`HOME` as MAVLink's degrees * 1e7 (spherical Earth)."""
    r = 6378137.0
    lat = HOME[0] + math.degrees(north_m / r)
    lon = HOME[1] + math.degrees(east_m / (r * math.cos(math.radians(HOME[0]))))
    return round(lat * 1e7), round(lon * 1e7)


def item(seq: int, command: int, north: float, east: float, alt: float) -> mi.MissionItem:
    x, y = latlon_e7(north, east)
    return mi.MissionItem(seq, mi.FRAME_GLOBAL_RELATIVE_ALT_INT, command, 0, 0, 0, math.nan, x, y, alt)


class TransferMismatch(Exception):
    """A mission downloaded differs from the one uploaded (a failed run, not a failure of the machinery)."""


def transfer_times(client: VehicleClient, n: int) -> tuple[float, float]:
    """Wall seconds to upload, then download, a mission of ``n`` waypoints; TransferMismatch if it comes back
    changed."""
    items = [item(k, mi.NAV_WAYPOINT, 0.5 * (k % 40), 0.5 * (k // 40), ALT_M) for k in range(n)]
    t0 = time.monotonic()
    upload(client, items, mi.MISSION)
    t1 = time.monotonic()
    back = download(client, mi.MISSION)
    t2 = time.monotonic()
    if [(b.x, b.y) for b in back] != [(i.x, i.y) for i in items]:
        raise TransferMismatch(f"the {n}-item mission downloaded differs from the one uploaded")
    return t1 - t0, t2 - t1


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance (m) from point ``p`` to the segment ``a``-``b`` (2-D)."""
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-9), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def square_figures(pts: np.ndarray, speeds: np.ndarray, side: float) -> dict[str, float]:
    """The flight figures of truth positions ``pts`` (N x 2, North/East m) and ground speeds (m/s)."""
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    legs = [(np.array(a), np.array(b)) for a, b in zip(corners[:-1], corners[1:])]
    xtrack = np.array([min(segment_distance(p, a, b) for a, b in legs) for p in pts])
    out = {"xtrack_rms_m": float(np.sqrt(np.mean(xtrack**2))), "xtrack_max_m": float(xtrack.max())}
    out["mean_speed_m_s"] = float(speeds.mean())
    for k, c in enumerate(corners[1:], start=1):
        out[f"corner{k}_m"] = float(np.linalg.norm(pts - np.array(c), axis=1).min())
    return out


def fly_square(client: VehicleClient, truth: SimClient, side: float) -> dict[str, Any]:
    """Upload and fly the square mission on a started stack; its figures (:func:`square_figures`, ``legs_s``)."""
    corners = [(side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    items = [item(0, mi.NAV_TAKEOFF, 0, 0, ALT_M)]
    items += [item(k + 1, mi.NAV_WAYPOINT, n, e, ALT_M) for k, (n, e) in enumerate(corners)]
    items.append(item(len(items), mi.NAV_LAND, 0, 0, 0))
    upload(client, items, mi.MISSION)
    client.wait_until(lambda: client.prearm_ok() and not client.armed(), READY_S, "ready to arm")
    client.set_mode("MISSION")
    wall0, sim0 = time.monotonic(), client.sim_time_s()
    ground_z = truth.latest().pos_ned_m[2]  # the start point's height (NED z, m), on the ground
    client.arm().check()
    current: dict[int, int] = {}  # item -> truth time (ms) it became current

    def on(msg) -> None:
        if msg.get_type() == "MISSION_CURRENT" and msg.seq not in current:
            current[msg.seq] = truth.latest().time_ms

    client.add_listener(on)
    client.wait_until(lambda: not client.armed() and len(current) > 3, MISSION_S, "the mission's landing")
    client.remove_listener(on)
    out: dict[str, Any] = {"sim_s": client.sim_time_s() - sim0, "wall_s": time.monotonic() - wall0}
    out["real_time_factor"] = out["sim_s"] / out["wall_s"]
    missing = [k for k in range(1, len(items)) if k not in current]
    if missing:
        return out | {"success": False, "status": "flight_failed", "reason": f"items never current: {missing}"}
    # the legs: from arriving at the first corner (item 2 current) to the touchdown after the last one
    start = current[2]
    down = [s.time_ms for s in truth.since(current[len(items) - 1]) if s.pos_ned_m[2] > ground_z - TOUCHDOWN_M]
    end = down[0] if down else truth.latest().time_ms
    samples = [s for s in truth.since(start) if s.time_ms <= end]
    pts = np.array([s.pos_ned_m[:2] for s in samples])
    speeds = np.array([math.hypot(*s.vel_ned_m_s[:2]) for s in samples])
    out.update(square_figures(pts, speeds, side), legs_s=(end - start) / 1000.0, success=True)
    return out


def _speed(v: Any) -> str | None:
    if v == "max":
        return None
    return number_in(0.1, 1000.0)(v) and f"{v!r} is not 'max' nor a real-time factor (0.1-1000)"


class MissionKind:
    """See the module docstring."""

    name = "mission"
    axes = (
        Axis("vehicle", ("quad_x",), vehicle_name, "vehicle file names"),
        Axis("side_m", (30.0,), number_in(5.0, 200.0), "the square's side, m"),
        Axis("wind", ("calm",), one_of("calm", "windy"), "wind case"),
        Axis("speed", ("max",), _speed, "simulator speed: max or a real-time factor"),
    )
    ranges = (Range("sim_seed", (0, 999_999), True, (0, 2**31 - 1), "simulator seed (sitl --seed)"),)
    figures = ("success", *FLIGHT_FIGURES, *TRANSFER_FIGURES, "sim_s", "wall_s", "real_time_factor")
    error_figure = "xtrack_rms_m"
    time_figure = "legs_s"
    time_header = "legs"

    def cells(self, grid: dict[str, tuple]) -> list[dict[str, Any]]:
        return grid_cells(grid, ("vehicle", "side_m", "wind", "speed"))

    def label(self, cell: dict[str, Any]) -> str:
        speed = "" if cell["speed"] == "max" else f" at {cell['speed']:g}x"
        return f"{cell['vehicle']} {cell['side_m']:g} m square {cell['wind']}{speed}"

    def fly(self, run: Run, ctx) -> dict[str, Any]:
        """Transfers and/or the flight (see the module docstring) on the run's own stack."""
        from mavsim_core import ports

        sim = {**(windy_parameters() if run.axes["wind"] == "windy" else {}), **ctx.settings.sim_params}
        stack = ctx.stack(run.axes["vehicle"], int(run.draws["sim_seed"]), sim_args(sim))
        stack.speed = str(run.axes["speed"])  # the cell's simulator speed (the context's default: max)
        stack.start()
        out: dict[str, Any] = {"success": True}
        with SimClient(ports.sim_component_port(ctx.instance)) as truth:
            client = ctx.client(timeout_s=60.0)
            client.wait_until(client.prearm_ok, READY_S, "ready to arm")
            transfers = bool(set(TRANSFER_FIGURES) & set(ctx.settings.record))
            for n in TRANSFER_ITEMS if transfers else ():
                try:
                    out[f"upload_{n}_s"], out[f"download_{n}_s"] = transfer_times(client, n)
                except TransferMismatch as exc:
                    return out | {"success": False, "status": "flight_failed", "reason": str(exc)}
            if set(FLIGHT_FIGURES) & set(ctx.settings.record) or not transfers:
                truth.wait_connected()
                out.update(fly_square(client, truth, float(run.axes["side_m"])))
        return out


KIND = MissionKind()
