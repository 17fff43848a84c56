"""The fields of a MAVLink command, read and checked: every value a command row uses goes through here.

MAVLink's conventions for COMMAND_LONG / COMMAND_INT parameters (the MAVLink command protocol and
each MAV_CMD's description in common.xml):

- NaN means "not given": use the default or keep the current value (NAV_TAKEOFF altitude NaN:
  MIS_TAKEOFF_ALT; a yaw NaN: keep the heading; a latitude/longitude NaN: here).  COMMAND_INT's x/y
  of INT32_MAX are the same (:func:`command_int_params` turns them into NaN).
- An infinity is never a valid value: a command with one in any parameter is refused.
- Enumerations and MAV_BOOL fields accept only their values ("Values not equal to 0 or 1 are invalid");
  whole-number fields (message ids, modes, motor numbers) only whole numbers in their range.

A field that breaks these raises :class:`FieldError`, whose text says which field and why; the command
table (:mod:`autopilot.mavlink.commands`) answers MAV_RESULT_DENIED and says it in a STATUSTEXT.

Units are those of the wire: degrees for latitude/longitude, metres AMSL (after :func:`to_amsl`) for
altitudes, radians for DO_REPOSITION's yaw.  Nothing here reads the vehicle's state except the home
altitude handed to :func:`to_amsl`.
"""

from __future__ import annotations

import math
from typing import Collection

from pymavlink.dialects.v20 import common as mavlink

INT32_MAX = 2**31 - 1  # COMMAND_INT x/y "not given"
MSG_ID_MAX = 2**24 - 1  # MAVLink 2 message ids are 24 bits
Params = tuple[float, ...]  # param1..param7; for COMMAND_INT x, y already in degrees (global frames) or m

AMSL_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT})
RELATIVE_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
TERRAIN_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
GLOBAL_FRAMES = AMSL_FRAMES | RELATIVE_FRAMES | TERRAIN_FRAMES
LOCAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_LOCAL_ENU, mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
    mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED, mavlink.MAV_FRAME_BODY_FRD,
    mavlink.MAV_FRAME_LOCAL_FRD, mavlink.MAV_FRAME_LOCAL_FLU,
})  # fmt: skip


class FieldError(ValueError):
    """A command field the command cannot accept; the text names the field and says why."""


def _show(x: float) -> str:
    return f"{x:g}"


def optional(x: float, name: str) -> float | None:
    """A float field: None when not given (NaN); an infinity is refused."""
    if math.isnan(x):
        return None
    if math.isinf(x):
        raise FieldError(f"{name} {_show(x)} is not a number")
    return float(x)


def required(x: float, name: str) -> float:
    """A float field that must be given (finite)."""
    value = optional(x, name)
    if value is None:
        raise FieldError(f"{name} not given")
    return value


def within(x: float, name: str, lo: float, hi: float) -> float:
    """A required float field in lo..hi."""
    value = required(x, name)
    if not lo <= value <= hi:
        raise FieldError(f"{name} {_show(value)} outside {_show(lo)}..{_show(hi)}")
    return value


def whole(x: float, name: str, lo: int, hi: int, nan: int | None = None) -> int:
    """A whole-number field in lo..hi; NaN gives ``nan`` (None: the field is required)."""
    if math.isnan(x) and nan is not None:
        return nan
    value = required(x, name)
    if value != int(value) or not lo <= value <= hi:
        raise FieldError(f"{name} {_show(value)} is not a whole number in {lo}..{hi}")
    return int(value)


def choice(x: float, name: str, allowed: Collection[int], nan: int | None = None) -> int:
    """An enumeration field: one of ``allowed``; NaN gives ``nan`` (None: required)."""
    if math.isnan(x) and nan is not None:
        return nan
    value = required(x, name)
    if value not in allowed:
        raise FieldError(f"{name} {_show(value)} is not one of {', '.join(str(a) for a in sorted(allowed))}")
    return int(value)


def flag(x: float, name: str, nan: bool | None = None) -> bool:
    """A MAV_BOOL field: exactly 0 or 1 ("values not equal to 0 or 1 are invalid"); NaN gives ``nan``."""
    return choice(x, name, (0, 1), None if nan is None else int(nan)) == 1


def message_id(x: float, name: str = "param1 (message id)") -> int:
    """A MAVLink message id (0..2^24-1)."""
    return whole(x, name, 0, MSG_ID_MAX)


def lat_lon(lat: float, lon: float, zero_is_here: bool = False) -> tuple[float, float] | None:
    """Latitude and longitude (degrees), both given or both not (NaN: None = here; with ``zero_is_here`` both
    0 too, as QGroundControl and MAVProxy send "here"); in -90..90 and -180..180."""
    la, lo = optional(lat, "latitude"), optional(lon, "longitude")
    if la is None and lo is None:
        return None
    if la is None or lo is None:
        raise FieldError("latitude and longitude must be given both or neither")
    if zero_is_here and la == 0.0 and lo == 0.0:
        return None
    if abs(la) > 90.0 or abs(lo) > 180.0:
        raise FieldError(f"latitude/longitude {_show(la)}, {_show(lo)} out of range")
    return la, lo


def yaw_rad(x: float, name: str = "param4 (yaw)") -> float | None:
    """A heading in radians (DO_REPOSITION, as the MAVLink spec, PX4 and MAVSDK), at most one turn either way;
    NaN: None (keep the heading)."""
    value = optional(x, name)
    if value is not None and abs(value) > 2 * math.pi:
        raise FieldError(f"{name} {_show(value)} rad is more than a turn (radians expected)")
    return value


def no_infinity(params: Params) -> None:
    """Refuse a command with an infinite parameter, used or not: no MAVLink field means anything by it."""
    for k, x in enumerate(params, start=1):
        if math.isinf(x):
            raise FieldError(f"param{k} is {_show(x)}")


def to_amsl(params: Params, frame: int, home_alt_amsl_m: float | None) -> Params:
    """A location command's parameters with param7 as metres AMSL, whatever COMMAND_INT frame it came in
    (COMMAND_LONG's are AMSL: MAV_FRAME_GLOBAL): relative-altitude frames add the home altitude; terrain and
    local frames are refused when the command gives a position (param5..7)."""
    if frame in AMSL_FRAMES or all(math.isnan(x) for x in params[4:7]):
        return params
    if frame in RELATIVE_FRAMES:
        if math.isnan(params[6]):
            return params
        if home_alt_amsl_m is None:
            raise FieldError("altitude above home given before a home position is set")
        return (*params[:6], params[6] + home_alt_amsl_m)
    if frame in TERRAIN_FRAMES:
        raise FieldError("terrain-relative altitudes are not supported (no terrain data)")
    raise FieldError(f"frame {frame} not supported for a global position")


def command_long_params(msg: mavlink.MAVLink_message) -> Params:
    """COMMAND_LONG's seven parameters, unchanged (positions: lat/lon degrees, altitude AMSL m)."""
    return (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)


def command_int_params(msg: mavlink.MAVLink_message) -> Params:
    """COMMAND_INT's parameters with x, y as floats: degE7 -> degrees in global frames, m * 1e4 -> m in
    local frames, INT32_MAX (both) = not given (NaN)."""
    if msg.x == INT32_MAX and msg.y == INT32_MAX:
        x = y = math.nan
    elif msg.frame in GLOBAL_FRAMES:
        x, y = msg.x * 1e-7, msg.y * 1e-7
    elif msg.frame in LOCAL_FRAMES:
        x, y = msg.x * 1e-4, msg.y * 1e-4
    else:
        x, y = float(msg.x), float(msg.y)
    return (msg.param1, msg.param2, msg.param3, msg.param4, x, y, msg.z)
