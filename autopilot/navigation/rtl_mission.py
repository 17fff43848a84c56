"""The mission's landing and the returns through the mission, as PX4's navigator plans them (RTL_TYPE 1-3).

A mission's landing sequence (:func:`landing_sequence`) starts at its first DO_LAND_START marker that a
NAV_LAND follows, or, without such a marker, at its first NAV_LAND (PX4's ``land_start_index``); it ends
at that NAV_LAND.  MAV_CMD_DO_LAND_START jumps there (the commander), and a return flies it when RTL_TYPE
says so (:func:`choose_return`, PX4 1.14's RTL_TYPE):

- 0: straight to the closest of home and the rally points (:class:`autopilot.navigation.rtl.ReturnTask`);
- 1: to the mission landing if there is one (the closest of it and the rally points), else home;
- 2: along the mission from the item being flown (or the closest one) to its landing; a mission without
  a landing is flown backwards to its first position item, then home, where the vehicle lands;
- 3: to the closest of home, the mission landing and the rally points.

The returns through the mission are flown by the mission runner (:class:`.mission.MissionTask`) on a list
of items made here: :func:`landing_items` (a climb to the return altitude first, as PX4's RTL mission
landing does, then the sequence), :func:`forward_items` and :func:`reverse_items`, in which every position
item becomes a plain waypoint (no hold time, no loiter: PX4's "fast" mission return) and only speed changes
and the landing itself keep their meaning.

Positions are metres NED from the estimator origin; items in MAVLink's units (degE7, m).
"""

from __future__ import annotations

import math
from dataclasses import replace
from enum import Enum

import numpy as np

from autopilot.navigation.mission import item_position
from autopilot.topics import HomePosition, VehicleEstimate
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem

# Items with a position a return flies through (a DO_LAND_START's optional position is not one).
FLOWN_POSITIONS = frozenset({mi.NAV_WAYPOINT, mi.NAV_LOITER_UNLIM, mi.NAV_LOITER_TIME, mi.NAV_TAKEOFF, mi.NAV_LAND})


class ReturnKind(Enum):
    DIRECT = "direct"  # the ReturnTask to a point (home or a rally point)
    MISSION_LANDING = "mission landing"  # climb, then straight to the landing sequence and fly it
    MISSION_FORWARD = "mission forward"  # the rest of the mission to its landing
    MISSION_REVERSE = "mission reverse"  # the mission backwards, then home


def landing_sequence(items: list[MissionItem]) -> tuple[int, int] | None:
    """(first item, NAV_LAND item) of the mission's landing, or None when it has no NAV_LAND."""
    lands = [k for k, it in enumerate(items) if it.command == mi.NAV_LAND]
    if not lands:
        return None
    for k, it in enumerate(items):
        if it.command == mi.DO_LAND_START:
            land = next((j for j in lands if j > k), None)
            if land is not None:
                return k, land
    return lands[0], lands[0]


def has_position(item: MissionItem) -> bool:
    """A position item a return can fly to (lat/lon 0/0 means "here" and is not a place to go back to)."""
    return item.command in FLOWN_POSITIONS and not (item.x == 0 and item.y == 0)


def choose_return(
    rtl_type: int,
    pos_ned_m: np.ndarray,
    home_ned_m: np.ndarray,
    rally_ned_m: list[np.ndarray],
    landing_ned_m: np.ndarray | None,
    has_mission: bool,
) -> tuple[ReturnKind, np.ndarray]:
    """Where a return goes for RTL_TYPE ``rtl_type``: its kind and, for a direct one, the point (m NED; for a
    mission landing, the NAV_LAND's position).  Distances are horizontal, from ``pos_ned_m``."""
    if rtl_type == 2:
        if landing_ned_m is not None:
            return ReturnKind.MISSION_FORWARD, landing_ned_m
        return (ReturnKind.MISSION_REVERSE if has_mission else ReturnKind.DIRECT), home_ned_m
    candidates: list[tuple[ReturnKind, np.ndarray]] = [] if rtl_type == 1 else [(ReturnKind.DIRECT, home_ned_m)]
    if landing_ned_m is not None and rtl_type in (1, 3):
        candidates.append((ReturnKind.MISSION_LANDING, landing_ned_m))
    candidates += [(ReturnKind.DIRECT, p) for p in rally_ned_m]
    if not candidates:  # RTL_TYPE 1 without a mission landing or a rally point: home
        return ReturnKind.DIRECT, home_ned_m
    return min(candidates, key=lambda c: float(np.linalg.norm(c[1][:2] - pos_ned_m[:2])))


def _as_waypoint(item: MissionItem) -> MissionItem:
    """A position item as a plain waypoint: no hold, the item's own acceptance radius, its yaw (NaN: keep)."""
    radius = item.param2 if item.command == mi.NAV_WAYPOINT else 0.0
    yaw = item.param4 if item.command in (mi.NAV_WAYPOINT, mi.NAV_TAKEOFF) else math.nan
    return replace(item, command=mi.NAV_WAYPOINT, param1=0.0, param2=radius, param3=0.0, param4=yaw)


def _fast(items: list[MissionItem]) -> list[MissionItem]:
    """The items a return flies, renumbered: positions as waypoints, the landing and speed changes kept."""
    out: list[MissionItem] = []
    for it in items:
        if it.command in (mi.NAV_LAND, mi.DO_CHANGE_SPEED):
            out.append(it)
        elif has_position(it):
            out.append(_as_waypoint(it))
    return [it.renumbered(k) for k, it in enumerate(out)]


def landing_items(items: list[MissionItem], seq: tuple[int, int], climb_to_amsl_m: float | None) -> list[MissionItem]:
    """The landing sequence ``seq`` as a return flies it (RTL_TYPE 1 and 3): a climb where the vehicle is to
    ``climb_to_amsl_m`` (m AMSL; None: no climb), then the sequence's items."""
    climb = []
    if climb_to_amsl_m is not None:  # lat/lon 0/0: the position where the return starts
        climb = [MissionItem(0, mi.FRAME_GLOBAL, mi.NAV_WAYPOINT, 0.0, 0.0, 0.0, math.nan, 0, 0, climb_to_amsl_m)]
    sequence = _fast(items[seq[0] : seq[1] + 1])
    return [*climb, *[it.renumbered(k + len(climb)) for k, it in enumerate(sequence)]]


def forward_items(items: list[MissionItem], start: int, land: int) -> list[MissionItem]:
    """The mission from item ``start`` to its NAV_LAND ``land`` as a return flies it (RTL_TYPE 2)."""
    return _fast(items[start : land + 1])


def reverse_items(items: list[MissionItem], start: int, home: HomePosition) -> list[MissionItem]:
    """The mission backwards from item ``start`` to its first position item, then home, where it lands
    (RTL_TYPE 2 without a mission landing); home is flown to at the altitude the vehicle has then."""
    back = [_as_waypoint(it) for it in reversed(items[: start + 1]) if has_position(it) and it.command != mi.NAV_LAND]
    land = MissionItem(0, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_LAND, 0.0, 0.0, 0.0, math.nan,
                       round(home.lat_deg * mi.DEG_E7), round(home.lon_deg * mi.DEG_E7), 0.0)  # fmt: skip
    return [it.renumbered(k) for k, it in enumerate([*back, land])]


def closest_item(items: list[MissionItem], est: VehicleEstimate, home: HomePosition, last: int) -> int | None:
    """The position item of ``items[: last + 1]`` closest to the vehicle (3-D), or None (PX4's closest item)."""
    best, best_d = None, math.inf
    for k, it in enumerate(items[: last + 1]):
        if has_position(it):
            d = float(np.linalg.norm(item_position(it, est, home) - est.pos_ned_m))
            if d < best_d:
                best, best_d = k, d
    return best
