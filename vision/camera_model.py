"""Pinhole camera intrinsics: from resolution and field of view (simulation) or an OpenCV
calibration file (a real camera).

Camera frame (OpenCV's): origin at the optical centre, x to the right in the image, y down in
the image, z along the optical axis (forward, out of the lens); metres.  Pixel (u, v) with
integer values at pixel centres, u to the right, v down.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics: image size (px), focal lengths fx, fy and principal point cx, cy (px), and
    OpenCV distortion coefficients (k1, k2, p1, p2[, k3, ...]; all zero for an ideal pinhole)."""

    width_px: int
    height_px: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = field(default=(0.0, 0.0, 0.0, 0.0, 0.0))

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 camera matrix K."""
        return np.array(((self.fx, 0.0, self.cx), (0.0, self.fy, self.cy), (0.0, 0.0, 1.0)))

    @property
    def dist_coeffs(self) -> np.ndarray:
        """The distortion coefficients as OpenCV takes them (float64 array)."""
        return np.asarray(self.distortion, dtype=np.float64)

    @property
    def horizontal_fov_rad(self) -> float:
        """Full horizontal field of view (rad), of the undistorted pinhole."""
        return 2.0 * math.atan(0.5 * self.width_px / self.fx)


def pinhole(width_px: int, height_px: int, horizontal_fov_rad: float) -> CameraModel:
    """Ideal pinhole with square pixels (fy = fx) and the principal point at the image centre
    ((width - 1) / 2, (height - 1) / 2 with pixel centres at integers), no distortion."""
    if width_px <= 0 or height_px <= 0 or not 0.0 < horizontal_fov_rad < math.pi:
        raise ValueError("pinhole: positive size and a field of view in (0, pi) rad needed")
    fx = 0.5 * width_px / math.tan(0.5 * horizontal_fov_rad)
    return CameraModel(width_px, height_px, fx, fx, 0.5 * (width_px - 1), 0.5 * (height_px - 1))


def _matrix_from_yaml_node(fs: cv2.FileStorage, key: str) -> np.ndarray:
    node = fs.getNode(key)
    if node.empty():
        raise ValueError(f"calibration file has no {key}")
    return np.asarray(node.mat(), dtype=np.float64)


def _read_calibration(path: Path) -> tuple[dict[str, object], np.ndarray, np.ndarray]:
    if path.suffix.lower() == ".json":
        doc = json.loads(path.read_text())
        return doc, np.asarray(doc["camera_matrix"], dtype=np.float64), np.asarray(doc["dist_coeffs"], dtype=float)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise ValueError(f"cannot read calibration file {path}")
    try:
        k = _matrix_from_yaml_node(fs, "camera_matrix")
        d = _matrix_from_yaml_node(fs, "dist_coeffs") if not fs.getNode("dist_coeffs").empty() else np.zeros(5)
        size = {name: int(fs.getNode(name).real()) for name in ("image_width", "image_height")}
    finally:
        fs.release()
    return dict(size), k, d


def load_calibration(path: str | Path, width_px: int | None = None, height_px: int | None = None) -> CameraModel:
    """A camera model from an OpenCV calibration file.

    YAML/XML (cv2.FileStorage, as OpenCV's calibration sample writes: ``camera_matrix`` and
    ``dist_coeffs`` as !!opencv-matrix, ``image_width``/``image_height``) or JSON
    (``{"camera_matrix": [[...]]*3, "dist_coeffs": [...], "image_width": ..., "image_height": ...}``).
    ``width_px``/``height_px`` override or supply the image size.
    """
    doc, k, d = _read_calibration(Path(path))
    k = k.reshape(3, 3)
    w = width_px if width_px is not None else int(doc.get("image_width", 0))  # type: ignore[call-overload]
    h = height_px if height_px is not None else int(doc.get("image_height", 0))  # type: ignore[call-overload]
    if w <= 0 or h <= 0:
        raise ValueError("calibration: image size unknown (give image_width/image_height)")
    return CameraModel(w, h, float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), tuple(d.ravel().tolist()))
