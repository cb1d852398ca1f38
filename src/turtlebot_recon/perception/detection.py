"""One marker seen in one image: what the detector gives the tracker.

Frames and conventions (as OpenCV's ArUco/IPPE and apriltag_ros's ``tag`` frame): the pose is
that of the marker frame in the camera's optical frame (x right, y down, z forward; REP-103).
The marker frame has its origin at the centre of the black square, x to the marker's right,
y up, z out of the marker towards whoever reads it (the outward normal of the wall it is on).
The corners are in image pixels, in OpenCV's order: top-left, top-right, bottom-right,
bottom-left as the marker is read.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TagDetection:
    family: str                 # canonical family name (families.canonical)
    id: int
    size_m: float               # edge of the black square (m), from the detector's config
    corners_px: np.ndarray      # (4, 2) float, image pixels (distorted, as in the image)
    position_m: np.ndarray      # (3,) marker centre in the camera optical frame
    rotation: np.ndarray        # (3, 3) rotation optical <- marker
    covariance: np.ndarray      # (6, 6) over (x, y, z, rx, ry, rz) in the optical frame:
                                # position (m²) and small rotations about its axes (rad²)
    decision_margin: float      # the back-end's decoding confidence (AprilTag's decision
                                # margin; OpenCV: the share of border bits read right, 0..1)
    reprojection_px: float      # RMS corner reprojection error of the chosen pose
    ambiguity: float            # IPPE: error of the chosen pose / error of the other (0..1);
                                # near 1 the two mirror poses explain the corners equally
    ambiguous: bool             # ambiguity above the detector's threshold: kept out of the map

    @property
    def distance_m(self) -> float:
        return float(np.linalg.norm(self.position_m))

    @property
    def normal(self) -> np.ndarray:
        """The marker's outward normal in the optical frame."""
        return self.rotation[:, 2]

    @property
    def obliquity_rad(self) -> float:
        """Angle between the line of sight and the marker's normal (0 = seen face on)."""
        los = -self.position_m / max(self.distance_m, 1e-9)
        return float(np.arccos(np.clip(los @ self.normal, -1.0, 1.0)))
