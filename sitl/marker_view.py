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
from vision.pad import PadLayout

MARGIN_PX = 8.0  # the sphere's image must miss the frame by more than this to count as out of view


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
