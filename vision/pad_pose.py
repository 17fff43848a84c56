"""The pad's pose from the image corners of the markers seen: ``cv2.solvePnPGeneric`` (both IPPE solutions).

Frames: the pad frame (:mod:`vision.pad`: origin at the pad's centre, z out of the pad towards the viewer) and the
camera frame (:mod:`vision.camera_model`: x right, y down, z along the optical axis); metres.

A planar target seen from far away, or a small one, has two poses that fit its corners about equally well (IPPE's
two solutions: the pad tilted one way or mirrored the other way about the line of sight).  Their rotations differ
by up to twice the angle between the line of sight and the pad's normal, their positions of the point the corners
are centred on hardly at all: so a pad whose markers are centred on its centre (:data:`vision.pad.NESTED_PAD`)
gets its centre right whichever is chosen, a lone marker away from the centre does not (its tilt error times its
offset).  OpenCV orders the solutions by reprojection error; :func:`solve_pad_pose` takes the first, or, when the
caller knows which way the pad faces (``up_cam``: the world's up in the camera frame, from the vehicle's attitude
and the gimbal's angles at capture, :func:`expected_normal_cam`; the deck is level), the one whose pad normal is
nearer to it.
"""

from __future__ import annotations

import cv2
import numpy as np

from mavsim_core import quaternion
from vision.camera_model import CameraModel
from vision.marker import marker_corners_3d
from vision.pad import PadMarker


def expected_normal_cam(rotation_frd_cam: np.ndarray, q_frd_to_ned: quaternion.Quat) -> np.ndarray:
    """The world's up (the normal of a level pad, unit) in the camera frame, from the camera -> body FRD rotation
    (its mount, gimbal angles included) and the vehicle's attitude (FRD -> NED)."""
    up_frd = quaternion.to_matrix(q_frd_to_ned).T @ np.array((0.0, 0.0, -1.0))
    return np.asarray(rotation_frd_cam, dtype=np.float64).T @ up_frd


def solve_pad_pose(
    seen: list[PadMarker], corners_px: np.ndarray, camera: CameraModel, up_cam: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """(rotation pad -> camera (3, 3), the pad's centre in the camera frame (3,), m) from the (4 n, 2) image
    corners of the n markers ``seen``, or None if OpenCV finds no pose.

    One marker: ``SOLVEPNP_IPPE_SQUARE`` in the marker's frame (the seed's solver), then moved to the pad's centre
    by the marker's offset.  Several: ``SOLVEPNP_IPPE`` over all their corners placed at their offsets on the pad.
    """
    if len(seen) == 1:
        object_points, flags = marker_corners_3d(seen[0].size_m), cv2.SOLVEPNP_IPPE_SQUARE
    else:
        object_points, flags = np.concatenate([m.corners_pad_m() for m in seen]), cv2.SOLVEPNP_IPPE
    n, rvecs, tvecs, _errors = cv2.solvePnPGeneric(
        object_points, corners_px, camera.matrix, camera.dist_coeffs, flags=flags
    )
    if n == 0:
        return None
    rotations = [cv2.Rodrigues(r)[0] for r in rvecs]
    k = 0
    if up_cam is not None:  # the pad normal (its z axis in the camera frame) nearest to the world's up
        k = int(np.argmax([rot[:, 2] @ up_cam for rot in rotations]))
    rot, t = rotations[k], np.asarray(tvecs[k], dtype=np.float64).ravel()
    if len(seen) == 1:
        t = t - rot @ np.array((seen[0].x_m, seen[0].y_m, 0.0))  # the pad's centre, from the marker's
    return rot, t
