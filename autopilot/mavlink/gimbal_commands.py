"""The gimbal manager's commands (:mod:`autopilot.mavlink.gimbal_manager`): each decodes MAVLink's fields and units
(degrees, NaN = not given, the COMMAND_INT frame's altitude) and acts on the manager; a refusal raises FieldError
(DENIED with a STATUSTEXT by the manager).  The manager runs them only once its device has reported.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.gimbal_pointing import CameraAttitude
from autopilot.mavlink import command_fields as f
from autopilot.mavlink.command_fields import FieldError
from autopilot.mavlink.gimbal_control import Roi

if TYPE_CHECKING:
    from autopilot.mavlink.gimbal_manager import GimbalManager

_TO_NEUTRAL = mavlink.GIMBAL_MANAGER_FLAGS_RETRACT | mavlink.GIMBAL_MANAGER_FLAGS_NEUTRAL
_YAW_EARTH = mavlink.GIMBAL_MANAGER_FLAGS_YAW_LOCK | mavlink.GIMBAL_MANAGER_FLAGS_YAW_IN_EARTH_FRAME


def check_device(m: GimbalManager, value: float, name: str) -> None:
    device = f.whole(value, name, 0, 255, nan=0)
    if device not in (0, m.device_compid):
        raise FieldError(f"{name} {device} is not this vehicle's gimbal device ({m.device_compid})")


def pitchyaw(m: GimbalManager, p: tuple, frame: int) -> int:
    """param1 pitch deg, param2 yaw deg (NaN: rates), param3/4 pitch/yaw rate deg/s, param5 flags,
    param7 gimbal device id."""
    check_device(m, p[6], "param7 (gimbal device id)")
    flags = f.whole(p[4], "param5 (flags)", 0, 2**32 - 1, nan=0)
    pitch, yaw = f.optional(p[0], "param1 (pitch)"), f.optional(p[1], "param2 (yaw)")
    if flags & _TO_NEUTRAL:
        att, rates = None, None
    elif pitch is not None and yaw is not None:
        att, rates = CameraAttitude(0.0, math.radians(pitch), math.radians(yaw), bool(flags & _YAW_EARTH)), None
    elif pitch is None and yaw is None:
        pr, yr = f.optional(p[2], "param3 (pitch rate)"), f.optional(p[3], "param4 (yaw rate)")
        att, rates = None, (math.radians(pr or 0.0), math.radians(yr or 0.0))
    else:
        raise FieldError("param1 (pitch) and param2 (yaw) must be given both or neither")
    why = m.point(m.command_source(), att, rates)
    if why is not None:
        raise FieldError(why)
    return mavlink.MAV_RESULT_ACCEPTED


def configure(m: GimbalManager, p: tuple, frame: int) -> int:
    """param1/2 primary sysid/compid, param3/4 secondary (NaN: -1, unchanged), param7 gimbal device id."""
    check_device(m, p[6], "param7 (gimbal device id)")
    names = ("param1 (primary sysid)", "param2 (primary compid)", "param3 (secondary sysid)",
             "param4 (secondary compid)")  # fmt: skip
    values = tuple(f.whole(v, n, -3, 255, nan=-1) for v, n in zip(p[:4], names))
    new = m.control.configured(values, m.command_source(), m.own)  # type: ignore[arg-type]
    if new != m.control:
        m.control, m.status_changed = new, True
        m.told.clear()
    return mavlink.MAV_RESULT_ACCEPTED


def roi_location(m: GimbalManager, p: tuple, frame: int) -> int:
    """param1 gimbal device id, param5/6 lat/lon deg, param7 altitude (AMSL, or above home by the
    COMMAND_INT frame)."""
    check_device(m, p[0], "param1 (gimbal device id)")
    home = m.vehicle_status().home
    p = f.to_amsl(p, frame, home.alt_amsl_m if home is not None else None)
    where = f.lat_lon(p[4], p[5])
    alt = f.optional(p[6], "param7 (altitude)")
    if where is None or alt is None:
        raise FieldError("latitude, longitude and altitude required")
    m.roi, m.rates_rad_s = Roi(where[0], where[1], alt), None
    m.sent = None  # the first ROI attitude goes out at the next update
    return mavlink.MAV_RESULT_ACCEPTED


def roi_none(m: GimbalManager, p: tuple, frame: int) -> int:
    """param1 gimbal device id: back to neutral."""
    check_device(m, p[0], "param1 (gimbal device id)")
    m.neutral()
    return mavlink.MAV_RESULT_ACCEPTED


# MAV_CMD -> (handler(manager, params, frame) -> MAV_RESULT, what a refusal's STATUSTEXT calls it)
TABLE: dict[int, tuple[Callable[..., int], str]] = {
    mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW: (pitchyaw, "Gimbal pitch/yaw"),
    mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE: (configure, "Gimbal configure"),
    mavlink.MAV_CMD_DO_SET_ROI_LOCATION: (roi_location, "ROI location"),
    mavlink.MAV_CMD_DO_SET_ROI_NONE: (roi_none, "ROI none"),
}
