"""Pad detection and pose: ``cv2.aruco.ArucoDetector`` + ``cv2.solvePnP`` over every marker of the pad in view.

The pose is that of the pad frame (:mod:`vision.pad`: origin at the pad's centre, the markers' common axes) in the
camera frame (:mod:`vision.camera_model`: x right, y down, z along the optical axis; metres), solved by
:mod:`vision.pad_pose`.  One marker seen: ``SOLVEPNP_IPPE_SQUARE`` on its four corners (the seed's method,
unchanged for the single-marker pad), then moved from the marker's centre to the pad's.  Several: one
``SOLVEPNP_IPPE`` (coplanar points) over all their corners, each marker's corners placed at its offset on the pad.
A marker drawn smaller than :data:`MIN_JOINT_SIDE_PX` in the image joins the pose only beside markers about as
small (at least :data:`SAME_SIZE` of the largest one seen): the small inner marker's cells are then 4 px or less,
smaller than the corner refinement's window, and its corners (worse still in a compressed video) pulled a 2.6 m
pose 8 cm off; the four large markers of the default pad, equally small from 3-4 m, all join (one of them alone,
0.47 m from the centre, turned IPPE's tilt ambiguity into 5-15 cm at the centre).

The detector looks the candidates up in a dictionary of the pad's own markers (:func:`pad_dictionary`), not in
all 1024 of ``DICT_ARUCO_ORIGINAL``: OpenCV compares every candidate that is no marker of its dictionary with
each of the dictionary's codes under four rotations, which was three quarters of a frame's detection (2.4 ->
0.55 ms on a landing's frames, benchmarks/README.md).  The pad's markers are found the same, corner for corner:
the dictionary corrects no bit (``maxCorrectionBits`` 1 times ``errorCorrectionRate`` 0.6 rounds to 0), so a
candidate is one of the pad's markers exactly when its bits are that marker's code, in either dictionary
(tests/test_vision_pad.py compares the two on noisy frames of the pad with another deck's beside it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from vision.camera_model import CameraModel
from vision.marker import MARKER_ID, MARKER_SIZE_M, dictionary
from vision.pad import PadLayout, PadMarker
from vision.pad_pose import expected_normal_cam, solve_pad_pose

__all__ = ["MIN_JOINT_SIDE_PX", "MarkerDetection", "MarkerDetector", "expected_normal_cam", "pad_dictionary"]

MIN_JOINT_SIDE_PX = 28.0  # a marker's mean side in the image (px) below which it joins only markers as small
SAME_SIZE = 0.8  # a marker whose image is at least this fraction of the largest one's is "as small"


@dataclass(frozen=True)
class MarkerDetection:
    """The pad seen in one frame.

    marker_id: the pad's id (its first marker's: LANDING_TARGET's ``target_num``), whichever markers were seen.
    marker_ids: the ids of the markers the pose was computed from, in the pad's order.
    corners_px: (4 n, 2) image corners (px) of those n markers, four a marker, each top-left, top-right,
    bottom-right, bottom-left of the printed marker.
    position_cam_m: the pad's centre in the camera frame (m).
    rotation_cam_marker: 3x3 rotation taking pad-frame vectors to the camera frame.
    distance_m: distance from the optical centre to the pad's centre (m).
    angle_x_rad, angle_y_rad: angular offset of the pad's centre from the optical axis along the
    image x and y axes, atan2(x, z) and atan2(y, z), as LANDING_TARGET's angle_x/angle_y ([MAV]).
    size_m: the side of the largest marker used (m).
    """

    marker_id: int
    corners_px: np.ndarray
    position_cam_m: np.ndarray
    rotation_cam_marker: np.ndarray
    distance_m: float
    angle_x_rad: float
    angle_y_rad: float
    size_m: float
    marker_ids: tuple[int, ...] = ()


RENDERED_THRESHOLD_WINDOW_PX = 13  # the middle one of OpenCV's default windows (3, 13, 23)


class MarkerDetector:
    """Finds a pad of ``DICT_ARUCO_ORIGINAL`` markers in greyscale or BGR frames.

    ``layout`` (:mod:`vision.pad`) gives its markers; without it the pad is the one marker ``marker_id`` of side
    ``size_m`` (default the seed's, 76 and 0.333 m).  ``rendered``: the frames are the simulator's (even light, no
    blur): the markers are thresholded with one window (RENDERED_THRESHOLD_WINDOW_PX) instead of OpenCV's three
    (3, 13 and 23 px), for 40 % less CPU and the same detections (benchmarks/pad_pose_benchmark.py, board+g, 200
    poses 0.3-4 m: 200/200 both, centre error median 0.4 / p95 2.5 cm both, 5.71 -> 3.46 ms a frame).  A real
    camera's video (``python -m vision``) keeps OpenCV's three.
    """

    def __init__(
        self,
        camera: CameraModel,
        marker_id: int = MARKER_ID,
        size_m: float = MARKER_SIZE_M,
        layout: PadLayout | None = None,
        rendered: bool = False,
    ) -> None:
        self.camera = camera
        self.layout = layout if layout is not None else PadLayout((PadMarker(marker_id, size_m),))
        self.marker_id = self.layout.pad_id
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX  # sub-pixel corners: cm-level pose
        if rendered:
            params.adaptiveThreshWinSizeMin = params.adaptiveThreshWinSizeMax = RENDERED_THRESHOLD_WINDOW_PX
        self._ids = np.array([m.marker_id for m in self.layout.markers])  # the pad dictionary's index -> id
        self._detector = cv2.aruco.ArucoDetector(pad_dictionary(self.layout), params)

    def detect(self, frame: np.ndarray, up_cam: np.ndarray | None = None) -> MarkerDetection | None:
        """The pad's detection in ``frame`` (uint8 grey or BGR), or None if none of its markers is seen.

        ``up_cam``: the world's up in the camera frame at capture, when known (:func:`expected_normal_cam`):
        of IPPE's two poses the one with the pad level is taken (:mod:`vision.pad_pose`)."""
        grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        corners, index, _rejected = self._detector.detectMarkers(grey)
        if index is None:
            return None
        found = {}  # every index is one of the pad's markers (pad_dictionary)
        for c, i in zip(corners, self._ids[index.ravel()].tolist()):
            if i not in found:  # the first of an id seen twice
                found[i] = np.asarray(c, dtype=np.float64).reshape(4, 2)
        seen = [m for m in self.layout.markers if m.marker_id in found]
        if len(seen) > 1:  # the markers large enough in the image, or as large as the largest one seen
            sides = {m.marker_id: _mean_side_px(found[m.marker_id]) for m in seen}
            enough = min(MIN_JOINT_SIDE_PX, SAME_SIZE * max(sides.values()))
            seen = [m for m in seen if sides[m.marker_id] >= enough]
        return self._pose(seen, np.concatenate([found[m.marker_id] for m in seen]), up_cam)

    def _pose(self, seen: list[PadMarker], corners_px: np.ndarray, up_cam: np.ndarray | None) -> MarkerDetection | None:
        pose = solve_pad_pose(seen, corners_px, self.camera, up_cam)
        if pose is None:
            return None
        rot, t = pose
        if not np.all(np.isfinite(t)) or t[2] <= 0.0:
            return None
        return MarkerDetection(
            marker_id=self.marker_id,
            corners_px=corners_px,
            position_cam_m=t,
            rotation_cam_marker=rot,
            distance_m=float(np.linalg.norm(t)),
            angle_x_rad=math.atan2(t[0], t[2]),
            angle_y_rad=math.atan2(t[1], t[2]),
            size_m=max(m.size_m for m in seen),
            marker_ids=tuple(m.marker_id for m in seen),
        )


def pad_dictionary(layout: PadLayout) -> cv2.aruco.Dictionary:
    """The dictionary of ``layout``'s markers: their ``DICT_ARUCO_ORIGINAL`` codes in the layout's order (a
    detection's index i is the id ``layout.markers[i].marker_id``), with that dictionary's bit correction."""
    full = dictionary()
    codes = full.bytesList[[m.marker_id for m in layout.markers]]
    return cv2.aruco.Dictionary(codes, full.markerSize, full.maxCorrectionBits)


def _mean_side_px(corners_px: np.ndarray) -> float:
    """The mean length (px) of the four sides of a marker's (4, 2) image corners."""
    return float(np.mean(np.linalg.norm(corners_px - np.roll(corners_px, 1, axis=0), axis=1)))
