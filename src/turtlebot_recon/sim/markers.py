"""Fiducial marker images (AprilTag and ArUco) from OpenCV's aruco module.

A marker of ``size`` metres (the edge of its black square, the AprilTag/ArUco convention) is
drawn with a white quiet zone one bit wide, so the printed square is ``bits + 2`` bits across
and its full image is ``(bits + 4) / (bits + 2)`` times ``size``.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..perception.families import dictionary  # noqa: F401  (re-exported for the tests)


def marker_bits(family: str) -> int:
    """Data bits per side (6 for tag36h11 and 6x6 ArUco)."""
    return int(dictionary(family).markerSize)


def full_scale(family: str) -> float:
    """Full image edge (quiet zone included) over the black square's edge."""
    b = marker_bits(family)
    return (b + 4) / (b + 2)


def marker_image(family: str, marker_id: int, px_per_bit: int = 16) -> np.ndarray:
    """Greyscale marker with a one-bit white quiet zone; (bits + 4) * px_per_bit square."""
    d = dictionary(family)
    if not 0 <= marker_id < d.bytesList.shape[0]:
        raise ValueError(f"marker id {marker_id} not in family '{family}' "
                         f"(0..{d.bytesList.shape[0] - 1})")
    b = int(d.markerSize)
    inner = cv2.aruco.generateImageMarker(d, marker_id, (b + 2) * px_per_bit, borderBits=1)
    return cv2.copyMakeBorder(inner, px_per_bit, px_per_bit, px_per_bit, px_per_bit,
                              cv2.BORDER_CONSTANT, value=255)
