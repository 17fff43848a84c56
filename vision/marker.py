"""The landing pad marker: ArUco id 76 of ``DICT_ARUCO_ORIGINAL``, 0.333 m side ([F 2.3]).

The document's board (``marker_size`` 0.3330 m, "in about 3.47 m available") is this marker.
Marker frame (OpenCV's, as solvePnP returns it): origin at the marker centre, x to the right
of the printed image, y up the printed image, z out of the marker towards the viewer; metres.
"""

from __future__ import annotations

import cv2
import numpy as np

MARKER_ID = 76
MARKER_DICTIONARY = cv2.aruco.DICT_ARUCO_ORIGINAL
MARKER_SIZE_M = 0.333  # side of the black square, border bit included ([F 2.3])
MARKER_BITS = 5  # DICT_ARUCO_ORIGINAL: 5x5 data bits, plus a one-bit black border each side


def dictionary() -> cv2.aruco.Dictionary:
    """The ArUco dictionary of the pad marker."""
    return cv2.aruco.getPredefinedDictionary(MARKER_DICTIONARY)


def marker_image(pixels_per_bit: int = 20, quiet_bits: int = 1, marker_id: int = MARKER_ID) -> np.ndarray:
    """The marker as a uint8 greyscale image (0 black, 255 white) with a white quiet border.

    The black square (border bit included) is ``(MARKER_BITS + 2) * pixels_per_bit`` pixels wide;
    ``quiet_bits`` bits of white surround it on every side (detection needs some white around).
    """
    side = (MARKER_BITS + 2) * pixels_per_bit
    inner = cv2.aruco.generateImageMarker(dictionary(), marker_id, side, borderBits=1)
    pad = quiet_bits * pixels_per_bit
    return cv2.copyMakeBorder(inner, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)


def marker_corners_3d(size_m: float = MARKER_SIZE_M) -> np.ndarray:
    """(4, 3) float64 corners of the black square in the marker frame (m), z = 0.

    Order as OpenCV's detector returns image corners and as ``SOLVEPNP_IPPE_SQUARE`` requires:
    top-left, top-right, bottom-right, bottom-left of the printed image.
    """
    h = 0.5 * size_m
    return np.array(((-h, h, 0.0), (h, h, 0.0), (h, -h, 0.0), (-h, -h, 0.0)), dtype=np.float64)
