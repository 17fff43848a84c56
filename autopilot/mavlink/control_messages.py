"""Messages that steer the vehicle from outside, decoded: MANUAL_CONTROL and the offboard setpoints.

:func:`manual_input` turns MANUAL_CONTROL (what QGroundControl's virtual joystick, a gamepad
through QGroundControl and MAVSDK's ManualControl send) into a
:class:`~autopilot.topics.ManualInput`: x (pitch, forward +), y (roll, right +) and r (yaw,
clockwise +) from -1000..1000 to -1..1, z (throttle) from 0..1000 to 0..1 (500 centred, as
MAVSDK and QGroundControl send it; PX4 reads z the same way).  A field outside its range is
clipped to it; the INT16_MAX "invalid" marker of x, y, z, r (MAVLink) counts as centred.
SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT and SET_ATTITUDE_TARGET are
decoded by :mod:`autopilot.mavlink.offboard_messages`.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from autopilot.topics import ManualInput

INT16_MAX = 32767  # MANUAL_CONTROL: "this axis is invalid"


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
    )
