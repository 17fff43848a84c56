"""Whether the landing pad's marker can be in the downward camera's frame: a cheap geometric test that lets
the lockstep companion (:mod:`sitl.companion`) skip rendering a frame that cannot show it.

The marker (a MARKER_SIZE_M square at the deck's centre) lies inside a sphere of radius
MARKER_SIZE_M / sqrt(2) around that centre.  The test is conservative: it says "out of view" only when
the whole sphere projects outside the image by more than MARGIN_PX, or lies behind the camera.  A frame
it skips is one in which the detector could not have found the marker: ArUco finds only a marker whose
four corners are all inside the image.  Rendering is most of the camera's cost (a frame ~9 ms, the
detection ~1 ms, two stacks on two cores), and in a landing most frames show no marker.

Frames: MuJoCo's world (ENU, m); MuJoCo's camera frame (x right, y up, looking along -z); pixels as
OpenCV's (u right, v down; :mod:`vision.camera_model`).  Positions are the ones the renderer draws
(``xpos``, ``cam_xpos`` of the same ``MjData``).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sitl.ugv import MARKER_SIZE_M, UgvGeometry
from vision.camera_model import CameraModel

MARGIN_PX = 8.0  # the sphere's image must miss the frame by more than this to count as out of view


def deck_centre_enu(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The centre of the deck's top (where the marker is) in the world frame (ENU, m)."""
    ugv = model.body("ugv").id
    geom = UgvGeometry()
    up = np.array([0.0, 0.0, geom.deck_top_m - geom.wheel_radius_m])
    return data.xpos[ugv] + data.xmat[ugv].reshape(3, 3) @ up


class MarkerView:
    """The view test for the camera ``camera_name`` of ``model`` with intrinsics ``camera`` (its pinhole)."""

    def __init__(self, model: mujoco.MjModel, camera_name: str, camera: CameraModel) -> None:
        self.model = model
        self.camera_id = model.camera(camera_name).id
        self.cam = camera
        self.radius_m = MARKER_SIZE_M / math.sqrt(2.0)

    def out_of_view(self, data: mujoco.MjData) -> bool:
        """True if no part of the marker can be in the frame rendered from ``data``."""
        c = deck_centre_enu(self.model, data)
        rot = data.cam_xmat[self.camera_id].reshape(3, 3)
        x, y_up, z_back = (rot.T @ (c - data.cam_xpos[self.camera_id])).tolist()
        depth, r = -z_back, self.radius_m
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
