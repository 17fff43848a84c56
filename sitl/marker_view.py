"""Whether any of the landing pad's markers can be in the downward camera's frame: a cheap geometric test that lets
the lockstep companion (:mod:`sitl.companion`) skip rendering a frame that cannot show one.

Each marker of the pad (:mod:`vision.pad`: a square of side s at its offset on the deck, the pad frame being the
UGV's body frame) lies inside a sphere of radius s / sqrt(2) around its centre.  The test is conservative: it says
"out of view" only when every marker's sphere projects outside the image by more than MARGIN_PX, or lies behind
the camera.  A frame it skips is one in which the detector could not have found a marker: ArUco finds only a
marker whose four corners are all inside the image.  Rendering is most of the camera's cost (a frame ~9 ms, the
detection ~1 ms, two stacks on two cores), and in a landing most frames show no marker.

Frames: MuJoCo's world (ENU, m); MuJoCo's camera frame (x right, y up, looking along -z); pixels as
OpenCV's (u right, v down; :mod:`vision.camera_model`).  Positions are the ones the renderer draws
(``xpos``, ``cam_xpos`` of the same ``MjData``).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sitl.ugv import UgvGeometry, ugv_part
from vision.camera_model import CameraModel
from vision.marker import marker_corners_3d
from vision.pad import PadLayout

MARGIN_PX = 8.0  # the sphere's image must miss the frame by more than this to count as out of view
# :meth:`MarkerView.detectable`: ArUco keeps a marker only with all four corners at least 3 px inside the image
# (minDistanceToBorder) and a perimeter of at least 0.03 of the image's larger side (minMarkerPerimeterRate).
# The test asks less, by these margins, so that it never skips a frame the detector could find a marker in.
CORNER_SLACK_PX = 2.0  # a corner may lie this far outside the image and the marker still count as findable
PERIMETER_RATE = 0.5 * 0.03  # half OpenCV's default minimum perimeter, as a fraction of the larger side


def deck_centre_enu(model: mujoco.MjModel, data: mujoco.MjData, ugv_k: int = 0) -> np.ndarray:
    """The centre of ground vehicle ``ugv_k``'s deck top (where the marker is) in the world frame (ENU, m)."""
    ugv = model.body(ugv_part(ugv_k, "ugv")).id
    geom = UgvGeometry()
    up = np.array([0.0, 0.0, geom.deck_top_m - geom.wheel_radius_m])
    return data.xpos[ugv] + data.xmat[ugv].reshape(3, 3) @ up


class MarkerView:
    """The view test for the camera ``camera_name`` of ``model`` with intrinsics ``camera`` (its pinhole), for the
    markers of ``pad`` on ground vehicle ``ugv_k``'s deck."""

    def __init__(
        self, model: mujoco.MjModel, camera_name: str, camera: CameraModel, pad: PadLayout, ugv_k: int = 0
    ) -> None:
        self.model, self.ugv_k = model, ugv_k
        self.camera_id = model.camera(camera_name).id
        self.cam = camera
        self._ugv = model.body(ugv_part(ugv_k, "ugv")).id
        # each marker's centre on the deck (the UGV's body frame, FLU m) and its bounding sphere's radius (m)
        self._centres_flu_m = [np.array((m.x_m, m.y_m, 0.0)) for m in pad.markers]
        self._radii_m = [m.size_m / math.sqrt(2.0) for m in pad.markers]
        # each marker's four corners on the deck (FLU m, around the square: the same polygon whichever way the
        # marker's own axes turn), (n, 4, 3)
        self._corners_flu_m = np.array(
            [marker_corners_3d(m.size_m) + c for m, c in zip(pad.markers, self._centres_flu_m)]
        )
        self._min_perimeter_px = PERIMETER_RATE * max(camera.width_px, camera.height_px)

    def out_of_view(self, data: mujoco.MjData) -> bool:
        """True if no part of any marker can be in the frame rendered from ``data``."""
        deck = deck_centre_enu(self.model, data, self.ugv_k)
        ugv_rot = data.xmat[self._ugv].reshape(3, 3)
        rot = data.cam_xmat[self.camera_id].reshape(3, 3)
        eye = data.cam_xpos[self.camera_id]
        return all(
            self._sphere_out_of_view(rot.T @ (deck + ugv_rot @ c - eye), r)
            for c, r in zip(self._centres_flu_m, self._radii_m)
        )

    def detectable(self, data: mujoco.MjData) -> bool:
        """False if the detector cannot find any marker in the frame rendered from ``data``: no marker has all
        four corners inside the image (within CORNER_SLACK_PX) and a perimeter of at least PERIMETER_RATE of the
        image's larger side; each marker's corners projected exactly as the renderer draws them (pinhole).  Stricter
        than :meth:`out_of_view` (which asks whether any part of a marker can be in the frame): a marker cut by the
        frame's edge, or too small to decode from afar, is in view but cannot be found."""
        deck = deck_centre_enu(self.model, data, self.ugv_k)
        ugv_rot = data.xmat[self._ugv].reshape(3, 3)
        rot = data.cam_xmat[self.camera_id].reshape(3, 3)
        cam = (deck + self._corners_flu_m @ ugv_rot.T - data.cam_xpos[self.camera_id]) @ rot  # (n, 4, 3) camera
        k, slack = self.cam, CORNER_SLACK_PX
        for corners in cam:
            depth = -corners[:, 2]
            if np.any(depth <= 1e-3):
                continue
            u, v = k.cx + k.fx * corners[:, 0] / depth, k.cy - k.fy * corners[:, 1] / depth
            if u.min() < -slack or v.min() < -slack or u.max() > k.width_px - 1 + slack:
                continue
            if v.max() > k.height_px - 1 + slack:
                continue
            if float(np.hypot(u - np.roll(u, 1), v - np.roll(v, 1)).sum()) >= self._min_perimeter_px:
                return True
        return False

    def _sphere_out_of_view(self, centre_cam_m: np.ndarray, r: float) -> bool:
        """A sphere of radius ``r`` (m) at ``centre_cam_m`` (MuJoCo's camera frame, m) wholly outside the image."""
        x, y_up, z_back = centre_cam_m.tolist()
        depth = -z_back
        if depth - r <= 1e-3:  # reaching the camera's plane: out only when wholly behind it
            return depth + r < 0.0
        k = self.cam
        # X/Z over the box [x +- r] x [depth +- r] (which holds the sphere) is extreme at its corners
        u_lo, u_hi = _ratio_range(x, depth, r)
        v_lo, v_hi = _ratio_range(-y_up, depth, r)
        u_min, u_max = k.cx + k.fx * u_lo, k.cx + k.fx * u_hi
        v_min, v_max = k.cy + k.fy * v_lo, k.cy + k.fy * v_hi
        w, h = k.width_px - 1, k.height_px - 1
        return u_max < -MARGIN_PX or u_min > w + MARGIN_PX or v_max < -MARGIN_PX or v_min > h + MARGIN_PX


def _ratio_range(lateral: float, depth: float, r: float) -> tuple[float, float]:
    """The least and greatest X / Z for X in [lateral - r, lateral + r] and Z in [depth - r, depth + r] (Z > 0)."""
    near, far = depth - r, depth + r
    lo, hi = lateral - r, lateral + r
    return min(lo / near, lo / far), max(hi / near, hi / far)
