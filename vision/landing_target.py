"""A marker detection -> the target's offset from the vehicle, and MAVLink LANDING_TARGET.

Frames:
- camera (OpenCV): x right in the image, y down in the image, z along the optical axis;
- body FRD: x forward, y right, z down; the vehicle attitude q (w, x, y, z) rotates FRD -> NED
  (:mod:`mavsim_core.quaternion`);
- the camera mount: ``rotation_frd_cam`` takes camera vectors to FRD, ``position_frd_m`` is the
  optical centre in FRD (m) from the vehicle's reference point (centre of mass).
  :data:`DOWNWARD_CAMERA` looks straight down: optical axis = body +z (down), image x (right) =
  body +y (right), image y (down the image) = body -x (backward), so the top of the image is forward.

LANDING_TARGET (#149, [MAV] common.xml): ``angle_x``/``angle_y`` rad, the target's angular offset
from the image centre; ``distance`` m; ``size_x``/``size_y`` rad, the target's angular size;
``x``/``y``/``z`` m in ``frame``; ``q`` (w, x, y, z) the target's orientation; ``type``
LANDING_TARGET_TYPE_VISION_FIDUCIAL; ``position_valid`` 1 when x/y/z are filled.
Two forms are built: PX4's (MAV_FRAME_LOCAL_NED) and ArduPilot's body form (MAV_FRAME_BODY_FRD:
x/y/z the target's offset from the vehicle along the body FRD axes, m).  For the NED form x/y/z
are the target's offset from the vehicle along NED axes (m) unless the vehicle's local NED
position is given; PX4's mavlink receiver reads them as the target's absolute local NED
position (landing_target_pose x_abs/y_abs/z_abs), so pass ``vehicle_position_ned_m`` to talk to PX4 itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import quaternion
from vision.detector import MarkerDetection


def _downward() -> np.ndarray:
    # columns: camera x, y, z axes expressed in FRD
    return np.array(((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)))


@dataclass(frozen=True)
class CameraMount:
    """Camera pose on the vehicle: optical centre in FRD (m) and the camera -> FRD rotation."""

    position_frd_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation_frd_cam: np.ndarray = field(default_factory=_downward)


DOWNWARD_CAMERA = CameraMount()


@dataclass(frozen=True)
class TargetOffset:
    """The marker centre relative to the vehicle's reference point (m), along FRD and NED axes."""

    frd_m: np.ndarray
    ned_m: np.ndarray


def target_offset(detection: MarkerDetection, mount: CameraMount, q_frd_to_ned: quaternion.Quat) -> TargetOffset:
    """The target's offset from the vehicle, from a detection, the mount and the attitude at capture."""
    frd = np.asarray(mount.position_frd_m, dtype=float) + mount.rotation_frd_cam @ detection.position_cam_m
    return TargetOffset(frd_m=frd, ned_m=quaternion.to_matrix(q_frd_to_ned) @ frd)


def _target_quaternion(detection: MarkerDetection, rotation_to_frame: np.ndarray) -> list[float]:
    """The marker orientation (marker frame -> ``frame``) as (w, x, y, z)."""
    return quaternion.from_matrix(rotation_to_frame @ detection.rotation_cam_marker).tolist()


def _angular_size(size_m: float, distance_m: float) -> float:
    return 2.0 * math.atan2(0.5 * size_m, distance_m)


def landing_target_message(
    detection: MarkerDetection,
    mount: CameraMount,
    q_frd_to_ned: quaternion.Quat,
    time_usec: int,
    frame: int = mavlink.MAV_FRAME_LOCAL_NED,
    vehicle_position_ned_m: tuple[float, float, float] | None = None,
) -> mavlink.MAVLink_landing_target_message:
    """LANDING_TARGET for a detection: PX4's NED form (default) or ArduPilot's MAV_FRAME_BODY_FRD form.

    ``time_usec`` is the capture time (us).  x/y/z as described in the module docstring.
    """
    offset = target_offset(detection, mount, q_frd_to_ned)
    if frame == mavlink.MAV_FRAME_LOCAL_NED:
        xyz = offset.ned_m
        if vehicle_position_ned_m is not None:
            xyz = xyz + np.asarray(vehicle_position_ned_m, dtype=float)
        rot = quaternion.to_matrix(q_frd_to_ned) @ mount.rotation_frd_cam
    elif frame == mavlink.MAV_FRAME_BODY_FRD:
        xyz, rot = offset.frd_m, mount.rotation_frd_cam
    else:
        raise ValueError(f"LANDING_TARGET frame {frame}: only MAV_FRAME_LOCAL_NED or MAV_FRAME_BODY_FRD")
    size = _angular_size(detection.size_m, detection.distance_m)
    return mavlink.MAVLink_landing_target_message(
        time_usec=int(time_usec),
        target_num=detection.marker_id & 0xFF,
        frame=frame,
        angle_x=detection.angle_x_rad,
        angle_y=detection.angle_y_rad,
        distance=detection.distance_m,
        size_x=size,
        size_y=size,
        x=float(xyz[0]),
        y=float(xyz[1]),
        z=float(xyz[2]),
        q=_target_quaternion(detection, rot),
        type=mavlink.LANDING_TARGET_TYPE_VISION_FIDUCIAL,
        position_valid=1,
    )
