"""Messages that steer the vehicle from outside, decoded: MANUAL_CONTROL and the offboard setpoints.

:func:`manual_input` turns MANUAL_CONTROL (what QGroundControl's virtual joystick, a gamepad
through QGroundControl and MAVSDK's ManualControl send) into a
:class:`~autopilot.topics.ManualInput`: x (pitch, forward +), y (roll, right +) and r (yaw,
clockwise +) from -1000..1000 to -1..1, z (throttle) from 0..1000 to 0..1 (500 centred, as
MAVSDK and QGroundControl send it; PX4 reads z the same way).  A field outside its range is
clipped to it; the INT16_MAX "invalid" marker of x, y, z, r (MAVLink) counts as centred.  The extension
fields as PX4 reads them: aux1..aux6 where ``enabled_extensions`` bits 2..7 say they are sent and they lie
within -1000..1000 (/1000), NaN otherwise; s (bit 0) and t (bit 1) the same way, buttons2 as sent (PX4
ignores these three).  Nothing flies on them (PX4's gimbal takes aux channels only from an RC-input mount
mode, MNT_MODE_IN 0 or 1 with MNT_MAN_*); the link echoes them in its MANUAL_CONTROL stream, as PX4 does.
SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT and SET_ATTITUDE_TARGET are
decoded by :mod:`autopilot.mavlink.offboard_messages`.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as mavlink

from autopilot.manual_input import AUX_CHANNELS, ManualInput

INT16_MAX = 32767  # MANUAL_CONTROL: "this axis is invalid"
S_BIT, T_BIT, AUX1_BIT = 1 << 0, 1 << 1, 1 << 2  # enabled_extensions: s, t, then aux1..aux6 at bits 2..7


def _axis(value: int, centre: float = 0.0, lo: float = -1.0) -> float:
    if value == INT16_MAX:
        return centre
    return min(max(value / 1000.0, lo), 1.0)


def manual_input(msg: mavlink.MAVLink_manual_control_message, now_us: int, wall_s: float) -> ManualInput:
    """A MANUAL_CONTROL as sticks (see the module docstring), stamped with both clocks."""
    return ManualInput(
        received_us=now_us,
        received_wall_s=wall_s,
        pitch=_axis(msg.x),
        roll=_axis(msg.y),
        throttle=_axis(msg.z, centre=0.5, lo=0.0),
        yaw=_axis(msg.r),
        buttons=int(msg.buttons),
        buttons2=int(getattr(msg, "buttons2", 0) or 0),
        aux=tuple(_extension(msg, f"aux{i + 1}", AUX1_BIT << i) for i in range(AUX_CHANNELS)),
        s=_extension(msg, "s", S_BIT),
        t=_extension(msg, "t", T_BIT),
    )


def _extension(msg: mavlink.MAVLink_manual_control_message, name: str, bit: int) -> float:
    """An extension axis as -1..1 when ``enabled_extensions`` has ``bit`` and it lies within -1000..1000; else NaN
    (a MAVLink 1 sender has no extensions: they read as 0, and so does the bitmask)."""
    value = getattr(msg, name, 0)
    if not int(getattr(msg, "enabled_extensions", 0) or 0) & bit or not -1000 <= value <= 1000:
        return math.nan
    return value / 1000.0
