"""Marker detection and pose: ``cv2.aruco.ArucoDetector`` + ``cv2.solvePnP(SOLVEPNP_IPPE_SQUARE)``.

The pose is that of the marker frame (:mod:`vision.marker`) in the camera frame
(:mod:`vision.camera_model`: x right, y down, z along the optical axis; metres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from vision.camera_model import CameraModel
from vision.marker import MARKER_ID, MARKER_SIZE_M, dictionary, marker_corners_3d


@dataclass(frozen=True)
class MarkerDetection:
    """One marker seen in one frame.

    corners_px: (4, 2) image corners (px), top-left, top-right, bottom-right, bottom-left of the marker.
    position_cam_m: marker centre in the camera frame (m).
    rotation_cam_marker: 3x3 rotation taking marker-frame vectors to the camera frame.
    distance_m: distance from the optical centre to the marker centre (m).
    angle_x_rad, angle_y_rad: angular offset of the marker centre from the optical axis along the
    image x and y axes, atan2(x, z) and atan2(y, z), as LANDING_TARGET's angle_x/angle_y ([MAV]).
    size_m: the marker side used for the pose (m).
    """

    marker_id: int
    corners_px: np.ndarray
    position_cam_m: np.ndarray
    rotation_cam_marker: np.ndarray
    distance_m: float
    angle_x_rad: float
    angle_y_rad: float
    size_m: float


class MarkerDetector:
    """Finds one marker id (default the pad's, 76) of ``DICT_ARUCO_ORIGINAL`` in greyscale or BGR frames."""

    def __init__(self, camera: CameraModel, marker_id: int = MARKER_ID, size_m: float = MARKER_SIZE_M) -> None:
        self.camera = camera
        self.marker_id = marker_id
        self.size_m = size_m
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX  # sub-pixel corners: cm-level pose
        self._detector = cv2.aruco.ArucoDetector(dictionary(), params)
        self._object_points = marker_corners_3d(size_m)

    def detect(self, frame: np.ndarray) -> MarkerDetection | None:
        """The marker's detection in ``frame`` (uint8 grey or BGR), or None if it is not seen."""
        grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        corners, ids, _rejected = self._detector.detectMarkers(grey)
        if ids is None:
            return None
        for c, i in zip(corners, ids.ravel().tolist()):
            if i == self.marker_id:
                return self._pose(np.asarray(c, dtype=np.float64).reshape(4, 2))
        return None

    def _pose(self, corners_px: np.ndarray) -> MarkerDetection | None:
        ok, rvec, tvec = cv2.solvePnP(
            self._object_points,
            corners_px,
            self.camera.matrix,
            self.camera.dist_coeffs,
            flags=cv2.SOLVEPNP_IPPE_SQUARE,
        )
        if not ok:
            return None
        t = np.asarray(tvec, dtype=np.float64).ravel()
        if not np.all(np.isfinite(t)) or t[2] <= 0.0:
            return None
        rot, _ = cv2.Rodrigues(rvec)
        return MarkerDetection(
            marker_id=self.marker_id,
            corners_px=corners_px,
            position_cam_m=t,
            rotation_cam_marker=rot,
            distance_m=float(np.linalg.norm(t)),
            angle_x_rad=math.atan2(t[0], t[2]),
            angle_y_rad=math.atan2(t[1], t[2]),
            size_m=self.size_m,
        )
