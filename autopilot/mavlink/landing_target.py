"""LANDING_TARGET -> :class:`LandingTargetMeasurement`, or a one-line refusal.

Three forms are accepted, as used in the field:

- PX4's (position_valid=1, MAV_FRAME_LOCAL_NED): PX4's MAVLink receiver copies x, y, z
  into ``landing_target_pose.x_abs/y_abs/z_abs``, i.e. the target's position in the
  local NED frame (relative to the local origin, not to the vehicle).  We do the same,
  so this form needs the vehicle's local position: rel = (x, y, z) - vehicle position.
- ArduPilot's body form (position_valid=1, MAV_FRAME_BODY_FRD): x, y, z is the target
  relative to the vehicle in body FRD metres; rotated to NED with the attitude.
- The angular form (position_valid=0, as from IR beacons): angle_x, angle_y (rad) are the
  target's offsets towards body x (forward) and y (right) of a downward-looking sensor;
  the line of sight in FRD is (tan angle_x, tan angle_y, 1).  With MAV_FRAME_BODY_NED or
  BODY_OFFSET_NED the angles are taken in a level, heading-aligned frame instead.  Range:
  ``distance`` (m) along the line of sight when > 0, otherwise scaled so the down
  component equals the distance above ground (as PX4's landing_target_estimator does).
  Frames LOCAL_NED, BODY_FRD, BODY_NED, BODY_OFFSET_NED and 0 (a MAVLink 1 sender
  without the extension fields) are accepted for this form.

A position form's ``q`` (the target's orientation in ``frame``: LOCAL_NED's axes, or body FRD's) gives the
heading of the target's edges modulo 90 deg (``square_yaw_rad``), when it is a unit quaternion whose z axis is
within 30 deg of the vertical (a marker lying on a deck, seen either way up); anything else (PX4's senders
often fill zeros), and the zero rotation exactly (1, 0, 0, 0: the placeholder of a sender that measures no
orientation, which no measured one ever is to the last bit), gives none, and the landing holds its own heading.

Anything else is refused with a reason short enough for one STATUSTEXT (50 characters).
Attitude: quaternion (w, x, y, z) rotating FRD into NED.  Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from autopilot.navigation.deck_heading import square
from autopilot.topics import LandingTargetMeasurement
from mavsim_core import quaternion as quat

MAV_FRAME_GLOBAL = 0
MAV_FRAME_LOCAL_NED = 1
MAV_FRAME_BODY_NED = 8
MAV_FRAME_BODY_OFFSET_NED = 9
MAV_FRAME_BODY_FRD = 12

_ANGULAR_FRAMES = (
    MAV_FRAME_GLOBAL,
    MAV_FRAME_LOCAL_NED,
    MAV_FRAME_BODY_NED,
    MAV_FRAME_BODY_OFFSET_NED,
    MAV_FRAME_BODY_FRD,
)
_MAX_ANGLE_RAD = math.radians(85.0)


@dataclass(frozen=True, slots=True)
class LandingTargetRefusal:
    """Why a LANDING_TARGET was not used: one line, at most 50 characters (one STATUSTEXT)."""

    reason: str


def _finite(*values: float) -> bool:
    return all(math.isfinite(float(v)) for v in values)


def _yaw_only(q_wxyz: np.ndarray) -> np.ndarray:
    _, _, yaw = quat.to_euler(q_wxyz)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _position_form(msg: Any, r_ned_frd: np.ndarray, vehicle_pos_ned_m: np.ndarray | None) -> np.ndarray | str:
    xyz = np.array([msg.x, msg.y, msg.z], dtype=float)
    if not _finite(*xyz):
        return "landing target: x/y/z not finite"
    if msg.frame == MAV_FRAME_LOCAL_NED:
        if vehicle_pos_ned_m is None or not _finite(*vehicle_pos_ned_m):
            return "landing target: no local position"
        return xyz - np.asarray(vehicle_pos_ned_m, dtype=float)
    if msg.frame == MAV_FRAME_BODY_FRD:
        return r_ned_frd @ xyz
    return f"landing target: frame {int(msg.frame)} unsupported"


def _angular_form(msg: Any, q_wxyz: np.ndarray, r_ned_frd: np.ndarray, dist_bottom_m: float) -> np.ndarray | str:
    if msg.frame not in _ANGULAR_FRAMES:
        return f"landing target: frame {int(msg.frame)} unsupported"
    if not _finite(msg.angle_x, msg.angle_y, msg.distance):
        return "landing target: angle/distance not finite"
    if abs(msg.angle_x) > _MAX_ANGLE_RAD or abs(msg.angle_y) > _MAX_ANGLE_RAD:
        return "landing target: angle out of range"
    if msg.distance < 0.0:
        return "landing target: negative distance"
    rot = _yaw_only(q_wxyz) if msg.frame in (MAV_FRAME_BODY_NED, MAV_FRAME_BODY_OFFSET_NED) else r_ned_frd
    ray_ned = rot @ np.array([math.tan(msg.angle_x), math.tan(msg.angle_y), 1.0])
    if msg.distance > 0.0:
        return ray_ned / np.linalg.norm(ray_ned) * float(msg.distance)
    if not (math.isfinite(dist_bottom_m) and dist_bottom_m > 0.0):
        return "landing target: no range and no height"
    if ray_ned[2] <= 0.1 * np.linalg.norm(ray_ned):
        return "landing target: line of sight not downward"
    return ray_ned / ray_ned[2] * float(dist_bottom_m)


SQUARE_TILT_MAX_RAD = math.radians(30.0)  # a target orientation tilted more than this gives no square heading


def square_yaw(q_target_wxyz: Any, frame: int, r_ned_frd: np.ndarray) -> float | None:
    """The heading of a level square target's edges (rad, NED, in [-pi/4, pi/4)) from LANDING_TARGET's ``q``
    (target -> ``frame``), or None (not a unit quaternion, the zero rotation's placeholder, not level within
    SQUARE_TILT_MAX_RAD, or a frame without axes of its own)."""
    try:
        q = np.asarray(q_target_wxyz, dtype=float).reshape(4)
    except (TypeError, ValueError):
        return None
    norm = float(np.linalg.norm(q))
    if not np.all(np.isfinite(q)) or abs(norm - 1.0) > 1e-2 or frame not in (MAV_FRAME_LOCAL_NED, MAV_FRAME_BODY_FRD):
        return None
    if q.tolist() == [1.0, 0.0, 0.0, 0.0]:  # a placeholder, not a measurement (the module docstring)
        return None
    rot = quat.to_matrix(q / norm)
    if frame == MAV_FRAME_BODY_FRD:
        rot = r_ned_frd @ rot
    if abs(float(rot[2, 2])) < math.cos(SQUARE_TILT_MAX_RAD):
        return None
    return square(math.atan2(float(rot[1, 0]), float(rot[0, 0])))  # its x axis (an edge) on the horizontal


def decode_landing_target(
    msg: Any,
    q_wxyz: np.ndarray,
    dist_bottom_m: float,
    vehicle_pos_ned_m: np.ndarray | None = None,
    timestamp_us: int | None = None,
) -> LandingTargetMeasurement | LandingTargetRefusal:
    """Decode a received pymavlink LANDING_TARGET message (any object with its fields).

    ``q_wxyz``: vehicle attitude, FRD -> NED.  ``dist_bottom_m``: height above ground,
    m (NaN if unknown).  ``vehicle_pos_ned_m``: the vehicle's local NED position, m,
    needed for PX4's LOCAL_NED form.  ``timestamp_us``: when the message was received
    on our clock; defaults to the message's ``time_usec``.
    """
    q = np.asarray(q_wxyz, dtype=float)
    if q.shape != (4,) or not _finite(*q) or abs(np.linalg.norm(q) - 1.0) > 1e-3:
        return LandingTargetRefusal("landing target: vehicle attitude unknown")
    r_ned_frd = quat.to_matrix(q)
    if msg.position_valid:
        rel = _position_form(msg, r_ned_frd, vehicle_pos_ned_m)
    else:
        rel = _angular_form(msg, q, r_ned_frd, dist_bottom_m)
    if isinstance(rel, str):
        return LandingTargetRefusal(rel)
    stamp = int(msg.time_usec) if timestamp_us is None else int(timestamp_us)
    edges = square_yaw(getattr(msg, "q", None), int(msg.frame), r_ned_frd) if msg.position_valid else None
    return LandingTargetMeasurement(
        timestamp_us=stamp,
        rel_pos_ned_m=rel,
        std_m=math.nan,
        source_frame=int(msg.frame),
        valid=True,
        angular=not msg.position_valid,
        square_yaw_rad=edges,
    )
