"""The gimbal device on the simulator link: GIMBAL_DEVICE_SET_ATTITUDE in, GIMBAL_DEVICE_ATTITUDE_STATUS out.

The flight controller's gimbal manager drives the simulated gimbal (:mod:`sitl.gimbal`) as PX4 drives one on
its own outputs: it sends the device's setpoint on the lockstep link, and the device reports the attitude its
encoders give back on the same link, STATUS_PERIOD_US apart in simulated time, for the manager to relay.

GIMBAL_DEVICE_SET_ATTITUDE ([MAV] common.xml, #284): ``q`` (w, x, y, z) the camera's attitude, its yaw in the
earth frame with YAW_LOCK or YAW_IN_EARTH_FRAME, else relative to the vehicle's heading (roll and pitch to the
horizon either way); all NaN: only rates, which this device does not take (the setpoint is kept); RETRACT or
NEUTRAL: back to the neutral (down).  A setpoint that is not a rotation is refused and counted, the gimbal keeps
what it held.

GIMBAL_DEVICE_ATTITUDE_STATUS (#285): ``q`` the camera's attitude from the encoders and the airframe, in the
frame its flags say (YAW_IN_VEHICLE_FRAME unless the setpoint locks yaw to the earth), ``angular_velocity_*``
its rate (rad/s, the difference of two reports), ``delta_yaw`` the vehicle's heading (rad), ``failure_flags``
the AT_*_LIMIT bits while a wanted attitude is beyond a joint's range.  Frames NED/FRD, radians.

GIMBAL_DEVICE_INFORMATION (#283), once a second of simulated time with a status: the joints' ranges (rad; roll,
pitch, yaw as the joints', which they are near level) and capability flags, for the manager's limits.
"""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import quaternion
from sitl.gimbal import Gimbal, GimbalSetpoint, Rows, body_yaw_rad, camera_attitude

STATUS_PERIOD_US = 20_000  # 50 Hz of simulated time
INFORMATION_PERIOD_US = 1_000_000  # GIMBAL_DEVICE_INFORMATION at 1 Hz
_CAP_FLAGS = (
    mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_NEUTRAL
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_ROLL_AXIS
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_ROLL_LOCK
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_AXIS
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_LOCK
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_AXIS
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_FOLLOW
    | mavlink.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_LOCK
)
_EARTH_YAW = mavlink.GIMBAL_DEVICE_FLAGS_YAW_LOCK | mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
_TO_NEUTRAL = mavlink.GIMBAL_DEVICE_FLAGS_RETRACT | mavlink.GIMBAL_DEVICE_FLAGS_NEUTRAL
_LIMIT_FLAGS = (
    mavlink.GIMBAL_DEVICE_ERROR_FLAGS_AT_YAW_LIMIT,
    mavlink.GIMBAL_DEVICE_ERROR_FLAGS_AT_ROLL_LIMIT,
    mavlink.GIMBAL_DEVICE_ERROR_FLAGS_AT_PITCH_LIMIT,
)


class GimbalDeviceLink:
    """One vehicle's gimbal device as the simulator link sees it (see the module docstring)."""

    def __init__(self, gimbal: Gimbal) -> None:
        self.gimbal = gimbal
        self.refused = 0  # setpoints that were not rotations
        self._last: tuple[int, tuple[float, float, float, float]] | None = None  # (time us, q) of the last report

    def handle(self, msg) -> bool:
        """Take a GIMBAL_DEVICE_SET_ATTITUDE (True); anything else is not this device's (False)."""
        if msg.get_type() != "GIMBAL_DEVICE_SET_ATTITUDE":
            return False
        flags = int(msg.flags)
        if flags & _TO_NEUTRAL:
            self.gimbal.setpoint = None
            return True
        q = [float(c) for c in msg.q]
        if all(math.isnan(c) for c in q):  # rates only: not taken, the attitude held
            return True
        try:
            self.gimbal.setpoint = GimbalSetpoint.from_quaternion(q, yaw_earth=bool(flags & _EARTH_YAW))
        except ValueError:
            self.refused += 1
        return True

    def status(self, time_us: int, data, r_ned_frd: Rows, mav: mavlink.MAVLink) -> bytes:
        """GIMBAL_DEVICE_ATTITUDE_STATUS packed, when one is due at ``time_us`` (else b"")."""
        if time_us % STATUS_PERIOD_US:
            return b""
        g = self.gimbal
        earth = g.setpoint is not None and g.setpoint.yaw_earth
        r_ng = camera_attitude(r_ned_frd, g.joints(data))
        heading = body_yaw_rad(r_ned_frd)
        if not earth:  # yaw relative to the vehicle's heading: Rz(-heading) R_ng
            c, s = math.cos(heading), math.sin(heading)
            (a, b, e), (f, h, i), last = r_ng
            r_ng = (
                (c * a + s * f, c * b + s * h, c * e + s * i),
                (-s * a + c * f, -s * b + c * h, -s * e + c * i),
                last,
            )
        q = tuple(float(x) for x in quaternion.from_matrix(np.array(r_ng)))
        rate = self._rate(time_us, q)
        self._last = (time_us, q)  # type: ignore[assignment]
        failure = 0
        if g.at_limit:  # which joints: those whose setpoint sits on an end of its range
            for bit, angle, (lo, hi) in zip(_LIMIT_FLAGS, g.command, g.limits):
                if angle <= lo + 1e-9 or angle >= hi - 1e-9:
                    failure |= bit
        flags = mavlink.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | mavlink.GIMBAL_DEVICE_FLAGS_PITCH_LOCK
        flags |= _EARTH_YAW if earth else mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
        msg = mavlink.MAVLink_gimbal_device_attitude_status_message(
            0, 0, time_us // 1000, flags, q, rate[0], rate[1], rate[2], failure, heading, math.nan, 1
        )
        data_out = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        if time_us % INFORMATION_PERIOD_US == 0:
            data_out = self.information(time_us, mav) + data_out
        return data_out

    def information(self, time_us: int, mav: mavlink.MAVLink) -> bytes:
        """GIMBAL_DEVICE_INFORMATION packed: the joints' ranges (rad) and what the device can do."""
        (ylo, yhi), (rlo, rhi), (plo, phi) = self.gimbal.limits
        msg = mavlink.MAVLink_gimbal_device_information_message(
            time_us // 1000, b"mavsim", b"sim gimbal", b"", 0, 0, 0, _CAP_FLAGS, 0, rlo, rhi, plo, phi, ylo, yhi, 0
        )
        data = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        return data

    def earth_attitude(self, data, q_ned_frd) -> mavlink.MAVLink_message:
        """The camera's true attitude (gimbal frame -> NED, from the joints and the airframe's attitude
        ``q_ned_frd``, w x y z) as a GIMBAL_DEVICE_ATTITUDE_STATUS in the earth frame: what the truth port reports."""
        m = quaternion.matrix_floats(*q_ned_frd)
        r_ned_frd: Rows = (m[0:3], m[3:6], m[6:9])  # type: ignore[assignment]
        q = [float(x) for x in quaternion.from_matrix(np.array(camera_attitude(r_ned_frd, self.gimbal.joints(data))))]
        nan = math.nan
        flags = _EARTH_YAW | mavlink.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | mavlink.GIMBAL_DEVICE_FLAGS_PITCH_LOCK
        return mavlink.MAVLink_gimbal_device_attitude_status_message(0, 0, 0, flags, q, nan, nan, nan, 0, nan, nan, 0)

    def _rate(self, time_us: int, q: tuple) -> tuple[float, float, float]:
        """The camera's angular rate (rad/s, its own axes) from the previous report's attitude to this one."""
        if self._last is None or time_us <= self._last[0]:
            return (math.nan, math.nan, math.nan)
        t0, q0 = self._last
        w0, x0, y0, z0 = q0
        d = quaternion.mul((w0, -x0, -y0, -z0), q)  # q0^-1 q
        if d[0] < 0:
            d = -d
        dt = (time_us - t0) * 1e-6
        return (2 * float(d[1]) / dt, 2 * float(d[2]) / dt, 2 * float(d[3]) / dt)
