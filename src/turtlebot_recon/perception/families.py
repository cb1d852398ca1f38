"""Marker families: one name for each, whichever way it is spelt.

AprilTag families are named as the AprilTag library names them (``tag36h11``); ArUco
dictionaries as the worlds name them (``aruco_6x6_100``). OpenCV's spelling is accepted for
both (``DICT_APRILTAG_36h11``, ``DICT_6X6_250``), case aside. An ArUco dictionary of N×N bits
with K markers holds the first K markers of every larger one of the same N (OpenCV builds
them so), so ``aruco_6x6_100`` and ``aruco_6x6_250`` share ids: ``marker_set`` gives the name
that detections and ground truth are matched on.
"""
from __future__ import annotations

import re

import cv2

APRILTAG = {
    "tag16h5": cv2.aruco.DICT_APRILTAG_16h5,
    "tag25h9": cv2.aruco.DICT_APRILTAG_25h9,
    "tag36h10": cv2.aruco.DICT_APRILTAG_36h10,
    "tag36h11": cv2.aruco.DICT_APRILTAG_36h11,
}
ARUCO = {f"aruco_{n}x{n}_{k}": getattr(cv2.aruco, f"DICT_{n}X{n}_{k}")
         for n in (4, 5, 6, 7) for k in (50, 100, 250, 1000)}
ARUCO["aruco_original"] = cv2.aruco.DICT_ARUCO_ORIGINAL
KNOWN = {**APRILTAG, **ARUCO}


def canonical(name: str) -> str:
    """The family's canonical name; ValueError naming the known families if there is none."""
    key = str(name).strip().lower()
    key = re.sub(r"^dict_", "", key)
    if key.startswith("apriltag_"):
        key = "tag" + key[len("apriltag_"):]
    elif re.fullmatch(r"\d+x\d+_\d+|original", key):
        key = "aruco_" + key
    if key not in KNOWN:
        raise ValueError(f"unknown marker family '{name}' (known: {', '.join(KNOWN)}; "
                         "OpenCV's DICT_ names are accepted too)")
    return key


def is_apriltag(family: str) -> bool:
    return canonical(family) in APRILTAG


def dictionary(family: str) -> cv2.aruco.Dictionary:
    return cv2.aruco.getPredefinedDictionary(KNOWN[canonical(family)])


def marker_set(family: str) -> str:
    """The name ids are compared under: ``aruco_6x6`` for every 6×6 ArUco dictionary (their
    ids agree), the canonical name otherwise."""
    c = canonical(family)
    m = re.fullmatch(r"(aruco_\d+x\d+)_\d+", c)
    return m.group(1) if m else c


def marker_count(family: str) -> int:
    return int(dictionary(family).bytesList.shape[0])
