"""The gimbal manager's commands and messages (:mod:`autopilot.mavlink.gimbal_manager`): each decodes MAVLink's
fields and units (degrees, NaN = not given) and acts on the manager through :class:`Gimbal`, the part of it they
use.  A command's refusal raises FieldError (DENIED with a STATUSTEXT by the manager), which runs them only once
its device has reported; a message's refusal (no ACK) is said once per client and kind until control changes.
"""

from __future__ import annotations

import math
from typing import Callable, Protocol

from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.gimbal_pointing import CameraAttitude, attitude_from_quaternion
from autopilot.mavlink import command_fields as f
from autopilot.mavlink.command_fields import FieldError
from autopilot.mavlink.gimbal_control import GimbalControl, Roi, Source
from autopilot.parameters import ParameterStore

_TO_NEUTRAL = mavlink.GIMBAL_MANAGER_FLAGS_RETRACT | mavlink.GIMBAL_MANAGER_FLAGS_NEUTRAL
_YAW_EARTH = mavlink.GIMBAL_MANAGER_FLAGS_YAW_LOCK | mavlink.GIMBAL_MANAGER_FLAGS_YAW_IN_EARTH_FRAME


class Gimbal(Protocol):
    """What the commands and messages read and set of the gimbal manager
    (:class:`autopilot.mavlink.gimbal_manager.GimbalManager`)."""

    params: ParameterStore
    control: GimbalControl  # who is in control
    own: Source  # the autopilot's (sysid, compid)
    roi: Roi | None
    rates_rad_s: tuple[float, float] | None
    sent: CameraAttitude | None  # what the device was last sent (None: send at the next update)

    @property
    def advertised(self) -> bool: ...
    @property
    def device_compid(self) -> int: ...
    def command_source(self) -> Source: ...
    def point(self, sender: Source, att: CameraAttitude | None, rates: tuple[float, float] | None) -> str | None: ...
    def set_control(self, control: GimbalControl) -> None: ...
    def neutral(self) -> None: ...
    def allows(self, sender: Source) -> bool: ...
    def tell_once(self, sender: Source, what: str, text: str) -> None: ...


def check_device(m: Gimbal, value: float, name: str) -> None:
    device = f.whole(value, name, 0, 255, nan=0)
    if device not in (0, m.device_compid):
        raise FieldError(f"{name} {device} is not this vehicle's gimbal device ({m.device_compid})")


def pitchyaw(m: Gimbal, p: tuple, frame: int) -> int:
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


def configure(m: Gimbal, p: tuple, frame: int) -> int:
    """param1/2 primary sysid/compid, param3/4 secondary (NaN: -1, unchanged), param7 gimbal device id."""
    check_device(m, p[6], "param7 (gimbal device id)")
    names = ("param1 (primary sysid)", "param2 (primary compid)", "param3 (secondary sysid)",
             "param4 (secondary compid)")  # fmt: skip
    values = tuple(f.whole(v, n, -3, 255, nan=-1) for v, n in zip(p[:4], names))
    m.set_control(m.control.configured(values, m.command_source(), m.own))  # type: ignore[arg-type]
    return mavlink.MAV_RESULT_ACCEPTED


def roi_location(m: Gimbal, p: tuple, frame: int) -> int:
    """param1 gimbal device id, param5/6 lat/lon deg, param7 altitude AMSL m whatever the COMMAND_INT frame, as
    PX4's navigator reads it (MAVSDK's Gimbal.set_roi_location sends AMSL in a MAV_FRAME_GLOBAL_RELATIVE_ALT
    COMMAND_INT; QGroundControl sends AMSL in MAV_FRAME_GLOBAL)."""
    check_device(m, p[0], "param1 (gimbal device id)")
    where = f.lat_lon(p[4], p[5])
    alt = f.optional(p[6], "param7 (altitude)")
    if where is None or alt is None:
        raise FieldError("latitude, longitude and altitude required")
    m.roi, m.rates_rad_s = Roi(where[0], where[1], alt), None
    m.sent = None  # the first ROI attitude goes out at the next update
    return mavlink.MAV_RESULT_ACCEPTED


def roi_none(m: Gimbal, p: tuple, frame: int) -> int:
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


# --------------------------------------------------------------------------- messages (no ACK)


def _message(m: Gimbal, msg, name: str, att: CameraAttitude | None, rates: tuple[float, float] | None) -> None:
    sender = (msg.get_srcSystem(), msg.get_srcComponent())
    if not m.advertised or int(msg.gimbal_device_id) not in (0, m.device_compid):
        return
    why = m.point(sender, att, rates)
    if why is not None:  # a stream of them says it once per client and kind until control changes
        m.tell_once(sender, "control" if not m.allows(sender) else "refused", f"{name} ignored: {why}")


def set_attitude(m: Gimbal, ep, msg) -> None:
    """GIMBAL_MANAGER_SET_ATTITUDE: ``q`` (NaN: rates only, angular_velocity_y/z rad/s), flags."""
    flags = int(msg.flags)
    att = attitude_from_quaternion(msg.q, bool(flags & _YAW_EARTH))
    if flags & _TO_NEUTRAL:
        return _message(m, msg, "Gimbal set attitude", None, None)
    rates = (float(msg.angular_velocity_y), float(msg.angular_velocity_z)) if att is None else None
    _message(m, msg, "Gimbal set attitude", att, rates)


def set_pitchyaw(m: Gimbal, ep, msg) -> None:
    """GIMBAL_MANAGER_SET_PITCHYAW: pitch, yaw rad (NaN: rates pitch_rate, yaw_rate rad/s), flags."""
    _pitch_yaw(m, msg, "Gimbal set pitch/yaw", float(msg.pitch), float(msg.yaw), 1.0, 1.0)


def set_manual_control(m: Gimbal, ep, msg) -> None:
    """GIMBAL_MANAGER_SET_MANUAL_CONTROL: pitch, yaw rad, or rates -1..1 of MNT_RATE_PITCH/YAW."""
    scale_p = math.radians(float(m.params.get("MNT_RATE_PITCH")))
    scale_y = math.radians(float(m.params.get("MNT_RATE_YAW")))
    _pitch_yaw(m, msg, "Gimbal manual control", float(msg.pitch), float(msg.yaw), scale_p, scale_y)


def _pitch_yaw(m: Gimbal, msg, name: str, pitch: float, yaw: float, scale_p: float, scale_y: float) -> None:
    flags = int(msg.flags)
    if flags & _TO_NEUTRAL:
        return _message(m, msg, name, None, None)
    if math.isfinite(pitch) and math.isfinite(yaw):
        return _message(m, msg, name, CameraAttitude(0.0, pitch, yaw, bool(flags & _YAW_EARTH)), None)
    rates = (float(msg.pitch_rate) * scale_p, float(msg.yaw_rate) * scale_y)
    _message(m, msg, name, None, rates)


# message type -> handler(manager, endpoint, message)
MESSAGES: dict[str, Callable[..., None]] = {
    "GIMBAL_MANAGER_SET_ATTITUDE": set_attitude,
    "GIMBAL_MANAGER_SET_PITCHYAW": set_pitchyaw,
    "GIMBAL_MANAGER_SET_MANUAL_CONTROL": set_manual_control,
}
