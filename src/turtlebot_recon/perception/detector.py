"""Fiducial marker detection with pose and covariance (ROS-free).

Two back-ends find markers and their corners behind one small contract (``Backend.find``):
OpenCV's aruco module, and the AprilTag 3 C library (``pupil_apriltags``), which reads only
AprilTag families, so ArUco families always go to OpenCV. Everything after the corners is
shared: sub-pixel corner refinement, the pose by ``cv2.solvePnPGeneric`` with
``SOLVEPNP_IPPE_SQUARE`` (both of IPPE's solutions), the checks that reject a detection, the
ambiguity test and the covariance.

Covariance: each corner is measured with an isotropic pixel noise ``sigma``, the larger of
``corner_sigma_px`` and the pose's RMS reprojection error; the pose's covariance is
``sigma² (JᵀJ)⁻¹`` with J the Jacobian of the four projected corners with respect to the pose
(marker position and a small rotation about the optical frame's axes), the Gauss–Newton
covariance at the solution. It grows with distance (the marker spans fewer pixels) and with
obliquity (foreshortening) as the geometry dictates, with nothing fitted.
"""
from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from ..config import ConfigError, require
from .detection import TagDetection
from .families import canonical, dictionary, is_apriltag, marker_set

BACKENDS = ("apriltag", "opencv")


@dataclass(frozen=True)
class TagSize:
    family: str                 # any spelling families.canonical accepts
    size_m: float               # edge of the black square
    id: int = -1                # -1: every id of the family not listed on its own


@dataclass(frozen=True)
class DetectorSettings:
    families: tuple[str, ...] = ("tag36h11", "aruco_6x6_250")
    backend: str = "apriltag"          # apriltag (AprilTag 3 for AprilTag families) | opencv
    default_size_m: float = 0.16       # size of a marker no entry of ``sizes`` covers
    sizes: tuple[TagSize, ...] = (     # per family or per (family, id)
        TagSize("tag36h11", 0.16), TagSize("aruco_6x6_250", 0.10))
    decimate: float = 1.0              # find quads on an image this many times smaller (slow CPUs);
                                       # the corners are refined on the full image
    refine_corners: bool = True        # cv2.cornerSubPix on the full-resolution image
    min_side_px: float = 12.0          # reject markers whose shortest side is shorter (px)
    border_px: float = 2.0             # reject markers with a corner this close to the image edge
    max_obliquity_rad: float = 1.22    # 70 deg between line of sight and the marker's normal
    max_reprojection_px: float = 1.5   # RMS corner reprojection error of the chosen pose
    ambiguity_ratio: float = 0.6       # IPPE: chosen / other reprojection error above this = ambiguous
    corner_sigma_px: float = 0.5       # corner noise floor for the covariance (px)
    max_distance_m: float = 8.0        # reject poses farther than this

    def validate(self, source: str) -> None:
        require(len(self.families) > 0, source, "families", "must list at least one family")
        for i, f in enumerate(self.families):
            try:
                canonical(f)
            except ValueError as exc:
                raise ConfigError(f"{source}/families[{i}]: {exc}") from None
        require(self.backend in BACKENDS, source, "backend",
                f"unknown back-end '{self.backend}' (known: {', '.join(BACKENDS)})")
        for key in ("default_size_m", "decimate", "min_side_px", "max_obliquity_rad",
                    "max_reprojection_px", "corner_sigma_px", "max_distance_m"):
            v = getattr(self, key)
            require(math.isfinite(v) and v > 0, source, key, f"must be a positive number, got {v!r}")
        require(self.decimate >= 1.0, source, "decimate", "must be >= 1")
        require(self.border_px >= 0, source, "border_px", "must be >= 0")
        require(0 < self.ambiguity_ratio <= 1, source, "ambiguity_ratio", "must be in (0, 1]")
        size_table(self, source)


@dataclass(frozen=True)
class DetectorNodeSettings:
    """scripts/tag_detector's parameters (config/tag_detector.yaml)."""
    transport: str = "raw"          # raw (image) | compressed (image/compressed)
    debug_image: bool = False       # publish ~debug_image (costs a colour copy per frame)
    detector: DetectorSettings = DetectorSettings()

    def validate(self, source: str) -> None:
        require(self.transport in ("raw", "compressed"), source, "transport",
                f"must be raw or compressed, got '{self.transport}'")


def size_table(s: DetectorSettings, source: str = "detector") -> dict:
    """{(marker_set, id or -1): size_m}; ConfigError for an unknown family, a bad size or one
    marker listed twice with different sizes."""
    table: dict = {}
    for i, e in enumerate(s.sizes):
        where = f"{source}/sizes[{i}]"
        try:
            key = (marker_set(e.family), int(e.id))
        except ValueError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        require(math.isfinite(e.size_m) and 0 < e.size_m <= 2.0, where, "size_m",
                f"must be a plausible marker size in m, got {e.size_m!r}")
        if key in table and table[key] != e.size_m:
            what = f"id {e.id}" if e.id >= 0 else "the family default"
            raise ConfigError(f"{where}: {key[0]} {what} listed twice with different sizes "
                              f"({table[key]} and {e.size_m} m)")
        table[key] = e.size_m
    return table


@dataclass
class Found:
    """A back-end's output for one marker: family, id, corners (4, 2) px, decision margin."""
    family: str
    id: int
    corners: np.ndarray
    margin: float


class OpenCVBackend:
    """cv2.aruco.ArucoDetector, one per family, on the image shrunk ``decimate`` times (the
    corners come back in full-image pixels; refinement is shared, on the full image).
    OpenCV reports no decoding confidence: the margin is the marker's bits per side."""

    def __init__(self, families: list, decimate: float = 1.0):
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
        self.detectors = [(f, cv2.aruco.ArucoDetector(dictionary(f), params)) for f in families]
        self.decimate = decimate

    def find(self, gray: np.ndarray) -> list:
        d = self.decimate
        if d > 1.0:
            gray = cv2.resize(gray, None, fx=1.0 / d, fy=1.0 / d, interpolation=cv2.INTER_AREA)
        out = []
        for fam, det in self.detectors:
            corners, ids, _ = det.detectMarkers(gray)
            if ids is None:
                continue
            bits = dictionary(fam).markerSize
            for c, i in zip(corners, ids.ravel()):
                c = c.reshape(4, 2).astype(np.float64)
                if d > 1.0:           # pixel centres: x_full = (x_small + 0.5) d - 0.5
                    c = (c + 0.5) * d - 0.5
                out.append(Found(fam, int(i), c, float(bits)))
        return out


def free_apriltag_detector(det) -> None:
    """Free a pupil_apriltags Detector's C side in the right order. Its own ``__del__`` frees
    the tag families first and then the detector, whose destroy still reads them: a
    use-after-free that crashes the process now and then (pupil-labs/apriltags issues 46, 52;
    fixed the same way in duckietown's dt-apriltags). Here the detector goes first, then the
    families, and ``__del__`` is left nothing to do."""
    ptr, det.tag_detector_ptr = det.tag_detector_ptr, None
    if ptr is None:
        return
    lib = det.libc
    lib.apriltag_detector_destroy.restype = None
    lib.apriltag_detector_destroy(ptr)
    for family, tf in det.tag_families.items():
        destroy = getattr(lib, f"{family}_destroy")
        destroy.restype = None
        destroy(tf)


class AprilTagBackend:
    """AprilTag 3 (pupil_apriltags) for the AprilTag families; OpenCV for the others."""

    def __init__(self, families: list, decimate: float = 1.0):
        import pupil_apriltags
        april = [f for f in families if is_apriltag(f)]
        # AprilTag 3 decimates only its quad search and decodes on the full image
        self.april = (pupil_apriltags.Detector(families=" ".join(april), nthreads=1,
                                               quad_decimate=decimate, refine_edges=1)
                      if april else None)
        if self.april is not None:
            weakref.finalize(self, free_apriltag_detector, self.april)
        rest = [f for f in families if not is_apriltag(f)]
        self.opencv = OpenCVBackend(rest, decimate) if rest else None

    def find(self, gray: np.ndarray) -> list:
        out = []
        if self.april is not None:
            for d in self.april.detect(np.ascontiguousarray(gray)):
                # pupil_apriltags lists the corners top-right, top-left, bottom-left, bottom-right
                # as the marker is read; OpenCV top-left, top-right, bottom-right, bottom-left
                c = np.asarray(d.corners, np.float64)[[1, 0, 3, 2]]
                out.append(Found(canonical(d.tag_family.decode() if isinstance(d.tag_family, bytes)
                                           else d.tag_family), int(d.tag_id), c, float(d.decision_margin)))
        if self.opencv is not None:
            out += self.opencv.find(gray)
        return out


def make_backend(name: str, families: list, decimate: float = 1.0):
    return (AprilTagBackend if name == "apriltag" else OpenCVBackend)(families, decimate)


class TagDetector:
    """Markers in one image → ``TagDetection`` list (camera optical frame).

    ``detect(gray, K, D)`` takes a greyscale uint8 image, the 3x3 camera matrix and the
    distortion coefficients (camera_info's K and D; D may be empty). ``rejected`` counts what
    was dropped and why since construction (the node reports it)."""

    def __init__(self, settings: DetectorSettings):
        settings.validate("detector")
        self.s = settings
        self.families = [canonical(f) for f in settings.families]
        self.sizes = size_table(settings)
        self.backend = make_backend(settings.backend, self.families, settings.decimate)
        self.rejected: dict = {}
        self.last_ms = 0.0

    def size_of(self, family: str, marker_id: int) -> float:
        key = marker_set(family)
        return self.sizes.get((key, marker_id), self.sizes.get((key, -1), self.s.default_size_m))

    def _count(self, why: str) -> None:
        self.rejected[why] = self.rejected.get(why, 0) + 1

    def detect(self, gray: np.ndarray, K: np.ndarray, D: Optional[np.ndarray] = None) -> list:
        t0 = time.perf_counter()
        gray = np.asarray(gray)
        if gray.ndim != 2 or gray.dtype != np.uint8 or gray.size == 0:
            raise ValueError(f"detect: expected a non-empty greyscale uint8 image, got "
                             f"{gray.dtype} {gray.shape}")
        K = np.asarray(K, np.float64).reshape(3, 3)
        D = np.zeros(0) if D is None else np.asarray(D, np.float64).ravel()
        if not (np.isfinite(K).all() and K[0, 0] > 0 and K[1, 1] > 0):
            raise ValueError(f"detect: camera matrix K has no positive focal lengths: {K.ravel().tolist()}")
        h, w = gray.shape
        out = []
        for f in self.backend.find(gray):
            c = f.corners
            b = self.s.border_px
            if (c[:, 0] < b).any() or (c[:, 1] < b).any() or (c[:, 0] > w - 1 - b).any() \
                    or (c[:, 1] > h - 1 - b).any():
                self._count("at_image_edge")
                continue
            if self.s.refine_corners:
                c = self._refine(gray, c)
            side = float(np.min(np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1)))
            if side < self.s.min_side_px:
                self._count("too_small")
                continue
            det = self._pose(f, c, K, D)
            if det is not None:
                out.append(det)
        self.last_ms = 1e3 * (time.perf_counter() - t0)
        return out

    def _refine(self, gray: np.ndarray, c: np.ndarray) -> np.ndarray:
        side = float(np.min(np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1)))
        h, w = gray.shape
        room = float(np.min([c[:, 0], c[:, 1], w - 1 - c[:, 0], h - 1 - c[:, 1]]))
        win = int(min(5, side / 8, room - 2))     # the search window stays inside the image
        if win < 1:
            return c
        pts = c.astype(np.float32).reshape(-1, 1, 2).copy()
        crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.01)
        cv2.cornerSubPix(gray, pts, (win, win), (-1, -1), crit)
        r = pts.reshape(4, 2).astype(np.float64)
        # a corner that wandered more than the window (a blurred or cut marker) keeps its place
        moved = np.linalg.norm(r - c, axis=1) > win
        r[moved] = c[moved]
        return r

    def _pose(self, f: Found, c: np.ndarray, K: np.ndarray, D: np.ndarray) -> Optional[TagDetection]:
        size = self.size_of(f.family, f.id)
        h = 0.5 * size
        obj = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)
        n, rvecs, tvecs, errs = cv2.solvePnPGeneric(obj, c, K, D, flags=cv2.SOLVEPNP_IPPE_SQUARE)
        if n < 1:
            self._count("no_pose")
            return None
        errs = np.asarray(errs, np.float64).ravel()
        order = np.argsort(errs)
        best = int(order[0])
        ratio = float(errs[best] / errs[order[1]]) if n > 1 and errs[order[1]] > 0 else 0.0
        rvec, tvec = rvecs[best].ravel(), tvecs[best].ravel()
        R = cv2.Rodrigues(rvec)[0]
        reproj = float(errs[best])
        dist = float(np.linalg.norm(tvec))
        los = -tvec / max(dist, 1e-9)
        obliquity = float(np.arccos(np.clip(los @ R[:, 2], -1.0, 1.0)))
        if tvec[2] <= 0 or dist > self.s.max_distance_m:
            self._count("too_far")
            return None
        if obliquity > self.s.max_obliquity_rad:
            self._count("too_oblique")
            return None
        if reproj > self.s.max_reprojection_px:
            self._count("reprojection_error")
            return None
        sigma = max(self.s.corner_sigma_px, reproj)
        cov = pose_covariance(obj, R, tvec, K, D, sigma)
        ambiguous = ratio > self.s.ambiguity_ratio
        if ambiguous:
            self._count("ambiguous")
        return TagDetection(family=f.family, id=f.id, size_m=size, corners_px=c, position_m=tvec.copy(),
                            rotation=R, covariance=cov, decision_margin=f.margin, reprojection_px=reproj,
                            ambiguity=ratio, ambiguous=ambiguous)


def _project(obj: np.ndarray, R: np.ndarray, t: np.ndarray, K: np.ndarray, D: np.ndarray) -> np.ndarray:
    p, _ = cv2.projectPoints(obj, cv2.Rodrigues(R)[0], t, K, D)
    return p.reshape(-1)


def pose_covariance(obj: np.ndarray, R: np.ndarray, t: np.ndarray, K: np.ndarray, D: np.ndarray,
                    sigma_px: float) -> np.ndarray:
    """6x6 covariance of (x, y, z, rx, ry, rz) in the optical frame: sigma² (JᵀJ)⁻¹, J the
    Jacobian (central differences) of the projected corners with respect to the position and
    to a small rotation exp([r]×) R about the optical frame's axes."""
    J = np.zeros((2 * len(obj), 6))
    for k in range(6):
        d = np.zeros(6)
        step = 1e-4
        d[k] = step
        plus = _project(obj, cv2.Rodrigues(d[3:])[0] @ R, t + d[:3], K, D)
        d[k] = -step
        minus = _project(obj, cv2.Rodrigues(d[3:])[0] @ R, t + d[:3], K, D)
        J[:, k] = (plus - minus) / (2 * step)
    info = J.T @ J
    try:
        return sigma_px ** 2 * np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return np.diag([1e6] * 6)

