"""Checks of mission items and whole plans, as the flight controller runs them at upload.

Each item is checked on arrival (:func:`check_item`): a command this stack does not fly, a
frame it cannot place, a NaN or out-of-range coordinate or parameter, an altitude above the
ceiling; the whole plan when the transfer completes (:func:`check_plan`): DO_JUMP targets,
fence polygons whose vertex counts do not add up.  Each check returns a MAV_MISSION_RESULT
(numbers from :mod:`mavsim_core.mission_items`) and a reason for the STATUSTEXT; anything but
ACCEPTED means nothing is stored, so an unsupported item is refused at upload and never
skipped in flight.  ACCEPTED with a reason is a note the protocol says: a fence circle of
radius 0, which MAVSDK's users send at (0, 0) when they want no circle (its ``GeofenceData``
carries polygons and circles together), is stored as PX4 stores it and ignored by the
geofence (it encloses nothing); a negative radius is refused.

Units: latitude/longitude degE7 (``x``/``y``), altitudes in metres (AMSL in the global
frames, above home in the relative ones), speeds m/s, times s, angles degrees (as MAVLink's
mission items carry them).
"""

from __future__ import annotations

import math

from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem

MAX_ITEMS = 2000  # per plan type: a larger MISSION_COUNT is answered MAV_MISSION_NO_SPACE
HARD_CEILING_M = 10000.0  # altitudes above home beyond this are refused even with GF_MAX_VER_DIST = 0

Result = tuple[int, str]
OK: Result = (mi.ACCEPTED, "")


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def _param_error(k: int, item: MissionItem, why: str) -> Result:
    """MAV_MISSION_INVALID_PARAMk (k 1..4) for ``item``."""
    return mi.INVALID_PARAM1 + k - 1, f"item {item.seq} ({item.name}): param{k} {why}"


def check_item(item: MissionItem, home_alt_amsl_m: float | None, ceiling_m: float) -> Result:
    """One item as it arrives: (MAV_MISSION_RESULT, reason).

    ``home_alt_amsl_m``: to compare AMSL altitudes with the ceiling (None: not known yet, only the
    relative ones are compared); ``ceiling_m``: the highest altitude above home allowed
    (GF_MAX_VER_DIST, or :data:`HARD_CEILING_M` when that is 0).
    """
    kind = mi.TYPE_NAMES.get(item.mission_type)
    if kind is None:
        return mi.UNSUPPORTED, f"mission type {item.mission_type} unknown"
    if item.command not in mi.SUPPORTED[item.mission_type]:
        return mi.UNSUPPORTED, f"item {item.seq}: {item.name} is not supported in a {kind} plan"
    if item.command in mi.POSITION_COMMANDS:
        result = _check_position(item, home_alt_amsl_m, ceiling_m)
        if result[0] != mi.ACCEPTED:
            return result
    return _check_params(item)


def _check_position(item: MissionItem, home_alt_amsl_m: float | None, ceiling_m: float) -> Result:
    if item.command == mi.DO_LAND_START and item.x == 0 and item.y == 0:
        return OK  # a marker without a position, in any frame (QGroundControl's plans also use MAV_FRAME_MISSION)
    if item.frame not in mi.POSITION_FRAMES:
        return mi.UNSUPPORTED_FRAME, f"item {item.seq} ({item.name}): frame {item.frame} not supported (use 0, 3, 5, 6)"
    if not abs(item.x) <= 90 * mi.DEG_E7:
        return mi.INVALID_PARAM1 + 4, f"item {item.seq} ({item.name}): latitude {item.x / mi.DEG_E7:g} out of range"
    if not abs(item.y) <= 180 * mi.DEG_E7:
        return mi.INVALID_PARAM1 + 5, f"item {item.seq} ({item.name}): longitude {item.y / mi.DEG_E7:g} out of range"
    if item.mission_type == mi.FENCE:
        return OK  # a fence vertex or centre: its altitude is not used
    if not math.isfinite(item.z):
        return mi.INVALID_PARAM1 + 6, f"item {item.seq} ({item.name}): altitude is not a number"
    if item.frame in mi.RELATIVE_FRAMES:
        above_home: float | None = item.z
    else:
        above_home = None if home_alt_amsl_m is None else item.z - home_alt_amsl_m
    if above_home is not None and above_home > ceiling_m:
        return (
            mi.INVALID_PARAM1 + 6,
            f"item {item.seq} ({item.name}): altitude {above_home:.1f} m above home is over the {ceiling_m:g} m limit",
        )
    if above_home is not None and above_home < -ceiling_m:
        return mi.INVALID_PARAM1 + 6, f"item {item.seq} ({item.name}): altitude {above_home:.1f} m is below home"
    return OK


def _check_params(item: MissionItem) -> Result:  # noqa: C901 - one branch per command
    p1, p2, p3, p4 = item.params
    c = item.command
    if c == mi.NAV_WAYPOINT:
        if not (_finite(p1) and 0 <= p1 <= 3600):
            return _param_error(1, item, "hold time must be 0-3600 s")
        if not (_finite(p2) and 0 <= p2 <= 1000):
            return _param_error(2, item, "acceptance radius must be 0-1000 m")
    elif c == mi.NAV_LOITER_TIME:
        if not (_finite(p1) and 0 <= p1 <= 86400):
            return _param_error(1, item, "loiter time must be 0-86400 s")
    elif c == mi.NAV_DELAY:
        if not (_finite(p1) and (p1 == -1 or 0 <= p1 <= 86400)):
            return _param_error(1, item, "delay must be 0-86400 s (time of day is not supported)")
    elif c == mi.NAV_LAND:
        if _finite(p2) and p2 not in (0, 1, 2):
            return _param_error(2, item, "precision land mode must be 0, 1 or 2")
    elif c == mi.DO_JUMP:
        if not (_finite(p1) and p1 >= 0 and p1 == int(p1)):
            return _param_error(1, item, "jump target must be an item number")
        if not (_finite(p2) and p2 >= -1 and p2 == int(p2)):
            return _param_error(2, item, "repeat count must be -1 (for ever) or >= 0")
    elif c == mi.DO_CHANGE_SPEED:
        if not (_finite(p2) and (p2 == -1 or 0 < p2 <= 20)):
            return _param_error(2, item, "speed must be -1 (default) or 0-20 m/s")
    elif c == mi.CONDITION_YAW:
        if not (_finite(p1) and 0 <= p1 <= 360):
            return _param_error(1, item, "heading must be 0-360 deg")
    elif c in (mi.FENCE_CIRCLE_INCLUSION, mi.FENCE_CIRCLE_EXCLUSION):
        if not (_finite(p1) and 0 <= p1 <= 100000):
            return _param_error(1, item, "radius must be 0-100000 m")
        if p1 == 0:
            return mi.ACCEPTED, f"item {item.seq}: circle of radius 0 ignored"  # it encloses nothing
    elif c in (mi.FENCE_POLYGON_INCLUSION, mi.FENCE_POLYGON_EXCLUSION):
        if not (_finite(p1) and p1 >= 3 and p1 == int(p1)):
            return _param_error(1, item, "vertex count must be 3 or more")
    if c in (mi.NAV_WAYPOINT, mi.NAV_TAKEOFF, mi.NAV_LAND, mi.NAV_LOITER_TIME, mi.NAV_LOITER_UNLIM):
        if not (math.isnan(p4) or -360 <= p4 <= 360):
            return _param_error(4, item, "yaw must be NaN (keep) or within +-360 deg")
    return OK


def check_plan(mission_type: int, items: list[MissionItem]) -> Result:
    """The whole mission once every item has arrived: DO_JUMP targets exist and are not the jump itself.
    (A fence's polygons are checked by :meth:`autopilot.navigation.geofence.Geofence.from_items`.)"""
    if mission_type == mi.MISSION:
        for it in items:
            if it.command == mi.DO_JUMP:
                target = int(it.param1)
                if target >= len(items) or target == it.seq:
                    return _param_error(1, it, f"jump target {target} is not another item of this mission")
                if items[target].command == mi.DO_JUMP:
                    return _param_error(1, it, f"jump target {target} is itself a DO_JUMP")
    return OK
