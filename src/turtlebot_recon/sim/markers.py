"""Fiducial marker images (AprilTag and ArUco) from OpenCV's aruco module.

A marker of ``size`` metres (the edge of its black square, the AprilTag/ArUco convention) is
drawn with a white quiet zone one bit wide, so the printed square is ``bits + 2`` bits across
and its full image is ``(bits + 4) / (bits + 2)`` times ``size``.
"""
from __future__ import annotations

import cv2
import numpy as np

APRILTAG_FAMILIES = {
    "tag16h5": cv2.aruco.DICT_APRILTAG_16h5,
    "tag25h9": cv2.aruco.DICT_APRILTAG_25h9,
    "tag36h10": cv2.aruco.DICT_APRILTAG_36h10,
    "tag36h11": cv2.aruco.DICT_APRILTAG_36h11,
}


def dictionary_id(family: str) -> int:
    """OpenCV dictionary for a family name: tag36h11, ..., aruco_6x6_100, aruco_4x4_50, ..."""
    if family in APRILTAG_FAMILIES:
        return APRILTAG_FAMILIES[family]
    name = "DICT_" + family.upper().removeprefix("ARUCO_").removeprefix("DICT_")
    if family.lower().startswith("aruco_") and hasattr(cv2.aruco, name):
        return getattr(cv2.aruco, name)
    raise ValueError(f"unknown marker family '{family}' (known: {sorted(APRILTAG_FAMILIES)} "
                     "and aruco_<N>x<N>_<count>, e.g. aruco_6x6_100)")


def dictionary(family: str) -> cv2.aruco.Dictionary:
    return cv2.aruco.getPredefinedDictionary(dictionary_id(family))


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
