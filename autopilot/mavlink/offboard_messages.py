"""Offboard setpoint messages, decoded: SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT and
SET_ATTITUDE_TARGET into :class:`~autopilot.topics.OffboardSetpoint` (what PX4's mavlink receiver makes of them).

Every frame is converted at reception to local NED (m, m/s, m/s^2 from the estimator origin ``est.origin_*``)
with the estimate of that moment; ``OffboardSetpoint.frame`` keeps the frame the sender used:

- MAV_FRAME_LOCAL_NED: as given.
- MAV_FRAME_LOCAL_OFFSET_NED: the position is an offset (NED) from the vehicle's position; velocity and
  acceleration NED.
- MAV_FRAME_BODY_NED: the position is local NED; velocity and acceleration are in the heading frame
  (forward, right, down: NED turned by the vehicle's yaw).
- MAV_FRAME_BODY_OFFSET_NED: the position too is an offset in the heading frame from the vehicle's position.
- SET_POSITION_TARGET_GLOBAL_INT in MAV_FRAME_GLOBAL(_INT): lat/lon degE7, altitude m AMSL; in
  MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT): altitude m above home.  Velocity and acceleration NED.  The terrain
  frames are not supported (no terrain data).

type_mask (POSITION_TARGET_TYPEMASK): a component whose IGNORE bit is set is NaN (not controlled); the yaw
(rad, absolute in every frame) and the yaw rate (rad/s) likewise.  The force bit (afx..afz as a force) is
not supported (PX4 ignores it too).  ``kind`` is the lowest level given: position, else velocity, else
acceleration.  In the body frames the horizontal pair of a vector is given both or neither.

SET_ATTITUDE_TARGET (ATTITUDE_TARGET_TYPEMASK): the quaternion q (w, x, y, z; FRD -> NED, normalised
here) with the body yaw rate fed forward when given, or, the attitude ignored, the body rates (rad/s, FRD;
an ignored rate is zero); thrust 0..1 of the maximum (clipped; NaN when THROTTLE_IGNORE: the task uses
the hover thrust).  A thrust vector (``thrust_body``, bit 5) is not supported.

A message that cannot be used (NaN or infinity in a field it uses, a zero quaternion, an unsupported frame
or mask, nothing given, no estimate / home where the conversion needs one) gives None; nothing raises.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.topics import HomePosition, OffboardKind, OffboardSetpoint, VehicleEstimate
from mavsim_core.frames import heading_to_ned
from mavsim_core.geodesy import geodetic_to_ned

F = mavlink
LOCAL_FRAMES = (F.MAV_FRAME_LOCAL_NED, F.MAV_FRAME_LOCAL_OFFSET_NED, F.MAV_FRAME_BODY_NED, F.MAV_FRAME_BODY_OFFSET_NED)
BODY_FRAMES = (F.MAV_FRAME_BODY_NED, F.MAV_FRAME_BODY_OFFSET_NED)
OFFSET_FRAMES = (F.MAV_FRAME_LOCAL_OFFSET_NED, F.MAV_FRAME_BODY_OFFSET_NED)
GLOBAL_AMSL_FRAMES = (F.MAV_FRAME_GLOBAL, F.MAV_FRAME_GLOBAL_INT)
GLOBAL_RELATIVE_FRAMES = (F.MAV_FRAME_GLOBAL_RELATIVE_ALT, F.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)

POS_BITS = (
    F.POSITION_TARGET_TYPEMASK_X_IGNORE,
    F.POSITION_TARGET_TYPEMASK_Y_IGNORE,
    F.POSITION_TARGET_TYPEMASK_Z_IGNORE,
)
VEL_BITS = (
    F.POSITION_TARGET_TYPEMASK_VX_IGNORE, F.POSITION_TARGET_TYPEMASK_VY_IGNORE, F.POSITION_TARGET_TYPEMASK_VZ_IGNORE
)  # fmt: skip
ACC_BITS = (
    F.POSITION_TARGET_TYPEMASK_AX_IGNORE, F.POSITION_TARGET_TYPEMASK_AY_IGNORE, F.POSITION_TARGET_TYPEMASK_AZ_IGNORE
)  # fmt: skip
RATE_BITS = (
    F.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE,
    F.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE,
    F.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE,
)
THRUST_BODY_SET = 32  # ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET (newer MAVLink): a thrust vector
MIN_QUAT_NORM = 1e-6


class Unusable(ValueError):
    """The message cannot be used (the module docstring); turned into None by :func:`offboard_setpoint`."""


def offboard_setpoint(
    msg: Any, now_us: int, wall_s: float, est: VehicleEstimate | None, home: HomePosition | None = None
) -> OffboardSetpoint | None:
    """The setpoint of an offboard message received at ``now_us`` (simulated µs) / ``wall_s`` (s), converted
    to local NED with ``est`` (and ``home`` for relative altitudes); None when it cannot be used."""
    try:
        kind = msg.get_type()
        if kind == "SET_POSITION_TARGET_LOCAL_NED":
            return _local(msg, now_us, wall_s, est)
        if kind == "SET_POSITION_TARGET_GLOBAL_INT":
            return _global(msg, now_us, wall_s, est, home)
        if kind == "SET_ATTITUDE_TARGET":
            return _attitude(msg, now_us, wall_s)
    except (Unusable, AttributeError, TypeError, ValueError, OverflowError):
        return None
    return None


def _given(mask: int, bits: tuple[int, ...], values: tuple[float, ...]) -> np.ndarray:
    """The components whose IGNORE bit is clear (must be finite), NaN for the others."""
    out = np.full(len(bits), math.nan)
    for i, (bit, value) in enumerate(zip(bits, values)):
        if not mask & bit:
            v = float(value)
            if not math.isfinite(v):
                raise Unusable("NaN or infinity in a used field")
            out[i] = v
    return out


def _common(msg: Any) -> tuple[int, np.ndarray, np.ndarray, float, float]:
    """type_mask, velocity and acceleration (as sent, NaN where ignored), yaw and yaw rate."""
    mask = int(msg.type_mask)
    if mask & F.POSITION_TARGET_TYPEMASK_FORCE_SET:
        raise Unusable("force setpoints are not supported")
    vel = _given(mask, VEL_BITS, (msg.vx, msg.vy, msg.vz))
    acc = _given(mask, ACC_BITS, (msg.afx, msg.afy, msg.afz))
    yaw = _given(mask, (F.POSITION_TARGET_TYPEMASK_YAW_IGNORE,), (msg.yaw,))[0]
    yaw_rate = _given(mask, (F.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,), (msg.yaw_rate,))[0]
    return mask, vel, acc, float(yaw), float(yaw_rate)


def _kind(pos: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> OffboardKind:
    for kind, v in ((OffboardKind.POSITION, pos), (OffboardKind.VELOCITY, vel), (OffboardKind.ACCELERATION, acc)):
        if np.isfinite(v).any():
            return kind
    raise Unusable("no position, velocity or acceleration given")


def body_to_ned(v: np.ndarray, yaw_rad: float) -> np.ndarray:
    """A vector of the heading frame (forward, right, down) in NED; its horizontal pair given both or neither."""
    if math.isnan(v[0]) != math.isnan(v[1]):
        raise Unusable("half a horizontal vector in a body frame")
    if math.isnan(v[0]):
        return v.copy()
    return np.append(heading_to_ned(v[0], v[1], yaw_rad), v[2])


def _needs_position(est: VehicleEstimate | None) -> VehicleEstimate:
    if est is None or not est.position_valid:
        raise Unusable("no position estimate")
    return est


def _local(msg: Any, now_us: int, wall_s: float, est: VehicleEstimate | None) -> OffboardSetpoint:
    frame = int(msg.coordinate_frame)
    if frame not in LOCAL_FRAMES:
        raise Unusable("unsupported frame")
    mask, vel, acc, yaw, yaw_rate = _common(msg)
    pos = _given(mask, POS_BITS, (msg.x, msg.y, msg.z))
    kind = _kind(pos, vel, acc)
    if frame in BODY_FRAMES:
        if est is None or not est.attitude_valid:
            raise Unusable("no heading estimate")
        vel, acc = body_to_ned(vel, est.yaw_rad), body_to_ned(acc, est.yaw_rad)
        if frame == F.MAV_FRAME_BODY_OFFSET_NED:
            pos = body_to_ned(pos, est.yaw_rad)
    if frame in OFFSET_FRAMES and kind is OffboardKind.POSITION:
        pos = pos + _needs_position(est).pos_ned_m
    return OffboardSetpoint(now_us, wall_s, kind, frame, pos, vel, acc, yaw, yaw_rate)


def _global(
    msg: Any, now_us: int, wall_s: float, est: VehicleEstimate | None, home: HomePosition | None
) -> OffboardSetpoint:
    frame = int(msg.coordinate_frame)
    if frame not in GLOBAL_AMSL_FRAMES + GLOBAL_RELATIVE_FRAMES:
        raise Unusable("unsupported frame")
    mask, vel, acc, yaw, yaw_rate = _common(msg)
    lla = _given(mask, POS_BITS, (msg.lat_int * 1e-7, msg.lon_int * 1e-7, msg.alt))
    pos = np.full(3, math.nan)
    if np.isfinite(lla).any():
        e = _needs_position(est)
        alt = lla[2]
        if frame in GLOBAL_RELATIVE_FRAMES and math.isfinite(alt):
            if home is None:
                raise Unusable("relative altitude without a home position")
            alt = alt + home.alt_amsl_m
        if not (abs(np.nan_to_num(lla[0])) <= 90.0 and abs(np.nan_to_num(lla[1])) <= 180.0):
            raise Unusable("latitude or longitude out of range")
        ned = geodetic_to_ned(
            np.nan_to_num(lla[0], nan=e.origin_lat_deg), np.nan_to_num(lla[1], nan=e.origin_lon_deg),
            alt if math.isfinite(alt) else e.origin_alt_amsl_m, e.origin_lat_deg, e.origin_lon_deg,
            e.origin_alt_amsl_m,
        )  # fmt: skip
        pos = np.where(np.isfinite([lla[0], lla[1], alt]), ned, math.nan)
    kind = _kind(pos, vel, acc)
    return OffboardSetpoint(now_us, wall_s, kind, frame, pos, vel, acc, yaw, yaw_rate)


def _attitude(msg: Any, now_us: int, wall_s: float) -> OffboardSetpoint:
    mask = int(msg.type_mask)
    if mask & THRUST_BODY_SET:
        raise Unusable("thrust vectors are not supported")
    thrust = _given(mask, (F.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE,), (msg.thrust,))[0]
    thrust = min(max(float(thrust), 0.0), 1.0) if math.isfinite(thrust) else math.nan
    rates = _given(mask, RATE_BITS, (msg.body_roll_rate, msg.body_pitch_rate, msg.body_yaw_rate))
    nan3 = np.full(3, math.nan)
    if not mask & F.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE:
        q = np.array([float(v) for v in msg.q])
        if q.shape != (4,) or not np.all(np.isfinite(q)):
            raise Unusable("NaN or infinity in the quaternion")
        norm = float(np.linalg.norm(q))
        if norm < MIN_QUAT_NORM:
            raise Unusable("zero quaternion")
        return OffboardSetpoint(
            now_us, wall_s, OffboardKind.ATTITUDE, F.MAV_FRAME_LOCAL_NED, nan3, nan3.copy(), nan3.copy(),
            math.nan, float(rates[2]), q_wxyz=q / norm, thrust_frac=thrust,
        )  # fmt: skip
    if not np.isfinite(rates).any():
        raise Unusable("neither an attitude nor body rates given")
    return OffboardSetpoint(
        now_us, wall_s, OffboardKind.BODY_RATES, F.MAV_FRAME_BODY_FRD, nan3, nan3.copy(), nan3.copy(),
        math.nan, math.nan, body_rate_frd_rad_s=np.nan_to_num(rates, nan=0.0), thrust_frac=thrust,
    )  # fmt: skip
