"""Annotated frames: the pad's markers outlined, the pad's axes, id, the markers used and distance drawn on a copy."""

from __future__ import annotations

import cv2
import numpy as np

from vision.camera_model import CameraModel
from vision.detector import MarkerDetection


def annotate(frame: np.ndarray, detection: MarkerDetection | None, camera: CameraModel) -> np.ndarray:
    """A BGR copy of ``frame`` (grey or BGR, uint8) with the detection drawn; unchanged copy if None.

    Each marker used outlined in green, the pad's axes at its centre by ``cv2.drawFrameAxes`` (x red, y green,
    z blue, half the largest marker's side long), and "id 76 (76+42)  1.23 m" above the first corner.
    """
    out = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame.copy()
    if detection is None:
        return out
    outlines = np.round(detection.corners_px).astype(np.int32).reshape(-1, 4, 1, 2)
    cv2.polylines(out, list(outlines), isClosed=True, color=(0, 255, 0), thickness=2)
    rvec, _ = cv2.Rodrigues(detection.rotation_cam_marker)
    tvec = detection.position_cam_m.reshape(3, 1)
    cv2.drawFrameAxes(out, camera.matrix, camera.dist_coeffs, rvec, tvec, 0.5 * detection.size_m, 2)
    x, y = (int(v) for v in np.round(detection.corners_px[0]))
    used = "+".join(str(i) for i in detection.marker_ids)
    label = f"id {detection.marker_id}{f' ({used})' if used else ''}  {detection.distance_m:.2f} m"
    cv2.putText(out, label, (x, max(y - 8, 12)), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 255), 1, cv2.LINE_AA)
    return out
