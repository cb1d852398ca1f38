"""Fiducial markers in the map: one estimate per marker, fused from its detections.

A detection (``TagDetection``: the marker's pose in the camera optical frame with a 6x6
covariance) becomes a map-frame sighting ``z = (x, y, z, yaw)`` with a 4x4 covariance, where
yaw is the heading of the marker's outward normal projected on the map's x-y plane (markers
hang on walls: their normal is horizontal). Each marker, keyed by (marker set, id), keeps a
Gaussian estimate over the same four quantities, updated per sighting like a Kalman filter on
a static landmark:

    innovation  nu = z - mean          (yaw wrapped into [-pi, pi))
    gate        d2 = nu' S^-1 nu,  S = P + R;   d2 > gate_chi2: the sighting is an outlier
    update      K = P S^-1,  mean += K nu,  P = (I - K) P (I - K)' + K R K'   (Joseph form)

A tag is tentative until ``confirm_sightings`` consistent sightings have been fused; then it
is confirmed and published. Camera pose uncertainty is not modelled (the caller gives the
optical frame's map pose as exact); ``min_position_std_m`` / ``min_yaw_std_rad`` bound how
much any one sighting is trusted.

Files: ``to_standalone_tags_yaml`` writes apriltag_ros's ``standalone_tags`` list (``id``,
``size``, ``name``, as apriltag_ros spells them) with our keys added to each entry; a loader of
that form ignores them. ``x y z qw qx qy qz`` are spelt as in apriltag_ros's ``tag_bundles``
layout; ``x y z yaw family size id`` as in a world file's ``tags``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Sequence, Tuple

import numpy as np
import yaml

from ..config import positive, require
from ..geometry import wrap_angle
from .detection import TagDetection
from .families import canonical, marker_set

TENTATIVE, CONFIRMED = "tentative", "confirmed"
STATES = (TENTATIVE, CONFIRMED)
# What ``TagTracker.update`` says happened to a detection.
OUTCOMES = ("tentative", "confirmed", "fused", "restarted", "rejected_outlier",
            "ignored_ambiguous", "ignored_far", "ignored_tilted", "ignored_size")
CSV_HEADER = "id,family,x,y,z,yaw,cov_xx,cov_xy,cov_yy,cov_zz,cov_yawyaw,sightings"


@dataclass(frozen=True)
class TrackerSettings:
    confirm_sightings: int = 2            # consistent (gated) sightings confirm a tag (seed 004)
    gate_chi2: float = 18.47              # Mahalanobis² gate over (x, y, z, yaw): chi² 4 dof 99.9%
                                          # (a right sighting fails 1 time in 1000; a flipped
                                          # pose or a misplaced id lands in the hundreds)
    restart_after_rejections: int = 3     # a tentative tag contradicted this many times in a row
                                          # is restarted from those sightings (its first sighting
                                          # was the wrong one)
    min_position_std_m: float = 0.01      # floor on a sighting's position std along any direction
    min_yaw_std_rad: float = 0.02         # floor on a sighting's yaw std
    max_distance_m: float = 4.0           # sightings farther from the camera are ignored (a
                                          # 0.16 m marker spans ~20 px there at 62 deg, 640 px)
    max_tilt_rad: float = 0.7854          # sightings whose normal leaves the horizontal by more
                                          # are ignored: wall markers are upright, and yaw is
                                          # ill-defined for a normal near vertical

    def __post_init__(self):
        self.validate(type(self).__name__)

    def validate(self, src: str) -> None:
        for key in ("confirm_sightings", "restart_after_rejections"):
            v = getattr(self, key)
            require(isinstance(v, int) and not isinstance(v, bool) and v >= 1, src, key,
                    f"must be an integer >= 1, got {v!r}")
        positive(src, self, "gate_chi2", "min_position_std_m", "min_yaw_std_rad",
                 "max_distance_m", "max_tilt_rad")
        require(self.max_tilt_rad < math.pi / 2, src, "max_tilt_rad",
                f"must be below pi/2 (yaw is undefined for a horizontal marker), "
                f"got {self.max_tilt_rad!r}")


@dataclass(frozen=True)
class TrackerNodeSettings:
    """scripts/tag_tracker's parameters (config/tag_tracker.yaml)."""
    map_frame: str = "odom"          # the mapper's frame until SLAM provides map -> odom
    tf_timeout_s: float = 0.1        # wait this long for the camera's transform at the stamp
    publish_rate_hz: float = 2.0     # /tags and /tags/markers
    tags_file: str = ""              # base path of tags.yaml / tags.csv ('' = $ROS_HOME/tags)
    save_on_shutdown: bool = True
    slam_landmarks: bool = False     # a tag in SLAM's graph (/slam/landmarks) takes the graph's x, y
    # tags.yaml/csv written (atomically) when a tag is confirmed or its estimate changes, at most
    # every autosave_min_period_s (sim); a tracker restarted mid-run (respawn) whose launch wrote
    # them (resume_key, $(anon run) from the launch files) goes on from them (docs/faults.md)
    autosave_min_period_s: float = 2.0   # s (sim)
    resume_key: str = ""
    tracker: TrackerSettings = TrackerSettings()

    def validate(self, source: str) -> None:
        require(self.tf_timeout_s >= 0, source, "tf_timeout_s", "must be >= 0")
        require(self.publish_rate_hz > 0, source, "publish_rate_hz", "must be > 0")
        require(self.autosave_min_period_s >= 0, source, "autosave_min_period_s", "must be >= 0")


@dataclass(frozen=True)
class TagTrack:
    """One marker's map estimate (map frame; m, rad)."""
    family: str                           # canonical name of its first sighting's family
    id: int
    size_m: float
    mean: Tuple[float, float, float, float]               # (x, y, z, yaw) of the marker centre
    covariance: Tuple[Tuple[float, ...], ...]             # 4x4 over mean (m², m·rad, rad²)
    sightings: int                        # sightings fused into mean
    rejected: int                         # sightings rejected as outliers
    first_seen_s: float                   # stamp of its first sighting
    last_seen_s: float                    # stamp of its last fused sighting
    state: str                            # "tentative" or "confirmed"

    @property
    def marker_set(self) -> str:
        return marker_set(self.family)

    @property
    def position_m(self) -> np.ndarray:
        return np.array(self.mean[:3])

    @property
    def yaw_rad(self) -> float:
        return self.mean[3]


# ------------------------------------------------------------------ sightings in the map

def sighting_in_map(detection: TagDetection, T_map_optical: np.ndarray):
    """The detection as a map-frame sighting: ``(z, R, tilt_rad)`` with z = (x, y, z, yaw),
    R its 4x4 covariance and tilt the angle of the marker's normal above or below horizontal.

    The 6x6 covariance is over the position and small rotations about the optical axes
    (R' = exp([d]x) R); both rotate into the map by R_map_optical. Yaw's row of the
    Jacobian w.r.t. a small map rotation d: the normal moves by d x n, so
    d yaw = (-nx nz d_x - ny nz d_y) / h² + d_z  with h² = nx² + ny² (vertical marker: d_z).
    """
    R_mo, t_mo = T_map_optical[:3, :3], T_map_optical[:3, 3]
    position = R_mo @ detection.position_m + t_mo
    n = R_mo @ detection.normal
    h2 = n[0] ** 2 + n[1] ** 2
    yaw = math.atan2(n[1], n[0])
    J = np.zeros((4, 6))
    J[:3, :3] = R_mo
    J[3, 3:] = np.array([-n[0] * n[2] / h2, -n[1] * n[2] / h2, 1.0]) @ R_mo if h2 > 0 else 0.0
    cov = J @ detection.covariance @ J.T
    z = np.array([*position, yaw])
    return z, 0.5 * (cov + cov.T), math.atan2(abs(n[2]), math.sqrt(h2))


def _floored(R: np.ndarray, min_position_std_m: float, min_yaw_std_rad: float) -> np.ndarray:
    """R with every position direction's variance and the yaw variance raised to the floors
    (by adding a positive semi-definite matrix, so R stays a covariance)."""
    R = R.copy()
    lam, V = np.linalg.eigh(R[:3, :3])
    R[:3, :3] += V @ np.diag(np.maximum(min_position_std_m ** 2 - lam, 0.0)) @ V.T
    R[3, 3] = max(R[3, 3], min_yaw_std_rad ** 2)
    return R


def _check_inputs(detection: TagDetection, T: np.ndarray, stamp_s: float) -> None:
    canonical(detection.family)              # ValueError naming an unknown family
    if not math.isfinite(stamp_s):
        raise ValueError(f"stamp_s must be finite, got {stamp_s!r}")
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"T_map_optical must be a finite 4x4 matrix, got {T!r}")
    if not np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-6):
        raise ValueError("T_map_optical: its 3x3 block is not a rotation")
    for key, shape in (("position_m", (3,)), ("rotation", (3, 3)), ("covariance", (6, 6))):
        v = np.asarray(getattr(detection, key))
        if v.shape != shape or not np.all(np.isfinite(v)):
            raise ValueError(f"detection.{key} must be finite with shape {shape}, got {v!r}")


# ------------------------------------------------------------------------------- tracker

@dataclass
class _Tag:
    """The tracker's working copy of one marker."""
    family: str
    id: int
    size_m: float
    mean: np.ndarray
    cov: np.ndarray
    first_seen_s: float
    last_seen_s: float
    sightings: int = 1
    rejected: int = 0
    state: str = TENTATIVE
    contradicted: List[Tuple[np.ndarray, np.ndarray, float]] = field(default_factory=list)
    # rejected sightings in a row (z, R, stamp_s), while tentative: the material of a restart

    def record(self) -> TagTrack:
        return TagTrack(self.family, self.id, self.size_m, tuple(float(v) for v in self.mean),
                        tuple(tuple(float(v) for v in row) for row in self.cov), self.sightings,
                        self.rejected, self.first_seen_s, self.last_seen_s, self.state)


@dataclass(frozen=True)
class Glimpse:
    """A marker seen but not confirmed: (x, y) m in the map and the yaw (rad) of the side to
    look at it from (its normal, or towards the camera that saw it)."""
    family: str
    id: int
    x: float
    y: float
    yaw: float
    stamp_s: float


class TagTracker:
    """Map estimates of markers from their detections (module docstring)."""

    def __init__(self, settings: TrackerSettings):
        self.settings = settings
        self._tags: Dict[Tuple[str, int], _Tag] = {}
        self._glimpses: Dict[Tuple[str, int], Glimpse] = {}
        self.stats = {key: 0 for key in ("sightings", "fused", "new", "confirmed", "restarted",
                                         "rejected_outlier", "ignored_ambiguous", "ignored_far",
                                         "ignored_tilted", "ignored_size")}

    def update(self, detection: TagDetection, T_map_optical: np.ndarray, stamp_s: float) -> str:
        """Take one detection seen from the optical frame at ``T_map_optical`` (its 4x4 pose in
        the map at the image stamp ``stamp_s``, s); returns one of OUTCOMES."""
        T = np.asarray(T_map_optical, dtype=float)
        _check_inputs(detection, T, stamp_s)
        s = self.settings
        self.stats["sightings"] += 1
        if detection.ambiguous or detection.distance_m > s.max_distance_m:
            self._glimpse(detection, T, stamp_s)
            return self._count("ignored_ambiguous" if detection.ambiguous else "ignored_far")
        z, R, tilt = sighting_in_map(detection, T)
        if tilt > s.max_tilt_rad:
            return self._count("ignored_tilted")
        R = _floored(R, s.min_position_std_m, s.min_yaw_std_rad)
        key = (marker_set(detection.family), int(detection.id))
        tag = self._tags.get(key)
        if tag is None:
            self._tags[key] = tag = _Tag(canonical(detection.family), int(detection.id),
                                         float(detection.size_m), z, R, stamp_s, stamp_s)
            self._count("new")
            return self._confirm_if_due(tag) or TENTATIVE
        if not math.isclose(detection.size_m, tag.size_m, rel_tol=1e-6):
            return self._count("ignored_size")     # another marker, or a misconfigured detector
        return self._sighting(tag, z, R, stamp_s)

    def _glimpse(self, detection: TagDetection, T: np.ndarray, stamp_s: float) -> None:
        """Remember where a marker kept out of the map (ambiguous or far) was seen, and from
        which side: the position is good even when the orientation is not."""
        p = T[:3, :3] @ detection.position_m + T[:3, 3]
        toward = T[:3, 3] - p                       # from the marker to the camera
        self._glimpses[(marker_set(detection.family), int(detection.id))] = Glimpse(
            canonical(detection.family), int(detection.id), float(p[0]), float(p[1]),
            math.atan2(toward[1], toward[0]), stamp_s)

    def unconfirmed(self) -> List["Glimpse"]:
        """Markers seen but not confirmed, for a closer look: tentative tracks (at their
        estimate, facing along their normal) and markers only glimpsed (ambiguous or far: at
        the glimpse, facing the camera that saw them), sorted by (family, id)."""
        out = {k: Glimpse(t.family, t.id, float(t.mean[0]), float(t.mean[1]), float(t.mean[3]),
                          t.last_seen_s)
               for k, t in self._tags.items() if t.state != CONFIRMED}
        for k, g in self._glimpses.items():
            if k not in self._tags:
                out[k] = g
        return sorted(out.values(), key=lambda g: (g.family, g.id))

    def restore(self, tracks: Sequence[TagTrack]) -> None:
        """Take back ``tracks`` (a tags.yaml this run's tracker saved before it died,
        ``load_tags_yaml``): each goes on as it was, its estimate, covariance, counts and state;
        a tag already tracked here keeps this tracker's estimate."""
        for t in tracks:
            key = (t.marker_set, int(t.id))
            if key not in self._tags:
                self._tags[key] = _Tag(t.family, int(t.id), float(t.size_m), np.array(t.mean, float),
                                       np.array(t.covariance, float), t.first_seen_s, t.last_seen_s,
                                       t.sightings, t.rejected, t.state)

    def tags(self, confirmed_only: bool = True) -> List[TagTrack]:
        """The tags' records, sorted by (family, id)."""
        records = [t.record() for t in self._tags.values()
                   if t.state == CONFIRMED or not confirmed_only]
        return sorted(records, key=lambda r: (r.family, r.id))

    # -------------------------------------------------------------------------- steps

    def _sighting(self, tag: _Tag, z: np.ndarray, R: np.ndarray, stamp_s: float) -> str:
        S = tag.cov + R
        nu = z - tag.mean
        nu[3] = wrap_angle(nu[3])
        if nu @ np.linalg.solve(S, nu) > self.settings.gate_chi2:
            return self._reject(tag, z, R, stamp_s)
        K = tag.cov @ np.linalg.inv(S)
        tag.mean = tag.mean + K @ nu
        tag.mean[3] = wrap_angle(tag.mean[3])
        I_K = np.eye(4) - K
        cov = I_K @ tag.cov @ I_K.T + K @ R @ K.T
        tag.cov = 0.5 * (cov + cov.T)
        tag.sightings += 1
        tag.last_seen_s = max(tag.last_seen_s, stamp_s)
        tag.contradicted.clear()
        self._count("fused")
        return self._confirm_if_due(tag) or ("fused" if tag.state == CONFIRMED else TENTATIVE)

    def _reject(self, tag: _Tag, z: np.ndarray, R: np.ndarray, stamp_s: float) -> str:
        tag.rejected += 1
        self._count("rejected_outlier")
        if tag.state == CONFIRMED:
            return "rejected_outlier"
        tag.contradicted.append((z, R, stamp_s))
        if len(tag.contradicted) < self.settings.restart_after_rejections:
            return "rejected_outlier"
        # Restart: the first contradicting sighting starts the estimate again and the others
        # are fused into it (through the gate: they must agree with one another).
        (z0, R0, t0), *rest = tag.contradicted
        tag.mean, tag.cov, tag.sightings, tag.last_seen_s = z0, R0, 1, t0
        tag.contradicted = []
        self._count("restarted")
        outcome = self._confirm_if_due(tag) or "restarted"
        for z1, R1, t1 in rest:
            if self._sighting(tag, z1, R1, t1) == CONFIRMED:
                outcome = CONFIRMED
        return outcome

    def _confirm_if_due(self, tag: _Tag):
        if tag.state == TENTATIVE and tag.sightings >= self.settings.confirm_sightings:
            tag.state = CONFIRMED
            return self._count(CONFIRMED)
        return None

    def _count(self, outcome: str) -> str:
        self.stats[outcome] += 1
        return outcome


# --------------------------------------------------------------------------------- files

def upright_quaternion(yaw_rad: float) -> Tuple[float, float, float, float]:
    """(qw, qx, qy, qz) of an upright marker (x horizontal, y up, z = outward normal at
    ``yaw_rad``) in the map: Rz(yaw) composed with the yaw-0 frame x->+y, y->+z, z->+x, a
    120° turn about (1, 1, 1) whose quaternion is (1, 1, 1, 1) / 2."""
    c, s = math.cos(yaw_rad / 2), math.sin(yaw_rad / 2)
    return (0.5 * (c - s), 0.5 * (c - s), 0.5 * (c + s), 0.5 * (c + s))


def _check_ids(entries: Sequence[Tuple[str, int, float]], where: Sequence[str]) -> None:
    """One entry per (marker set, id). The same id in two marker sets (tag36h11 3 and ArUco 3)
    are two markers and may differ in size; apriltag_ros, which keys its tags by id alone,
    reads such a file's first entry for that id (their names tell them apart)."""
    seen: Dict[Tuple[str, int], str] = {}
    for (family, tag_id, _size), here in zip(entries, where):
        key = (marker_set(family), tag_id)
        if key in seen:
            raise ValueError(f"{here}: id {tag_id} of {key[0]} is listed twice (also {seen[key]})")
        seen[key] = here


def to_standalone_tags_yaml(tracks: Sequence[TagTrack], resume_key: str = "") -> str:
    """The tracks as apriltag_ros's ``standalone_tags`` list plus our keys (module docstring).
    ``name`` is apriltag_ros's default ``tag_<id>``, or ``<marker set>_tag_<id>`` for an id
    that two marker sets share. ``resume_key`` (the tracker's launch; '' = none) is written as
    a top-level key for ``resumable_tracks``."""
    _check_ids([(t.family, t.id, t.size_m) for t in tracks],
               [f"track {t.family}/{t.id}" for t in tracks])
    ids = [t.id for t in tracks]
    entries = []
    for t in tracks:
        qw, qx, qy, qz = upright_quaternion(t.yaw_rad)
        x, y, z, yaw = t.mean
        entries.append({
            "id": t.id, "size": t.size_m,
            "name": f"tag_{t.id}" if ids.count(t.id) == 1 else f"{t.marker_set}_tag_{t.id}",
            "family": t.family, "x": x, "y": y, "z": z, "yaw": yaw,
            "qw": qw, "qx": qx, "qy": qy, "qz": qz,
            "covariance": [list(row) for row in t.covariance],
            "sightings": t.sightings, "rejected": t.rejected,
            "first_seen_s": t.first_seen_s, "last_seen_s": t.last_seen_s, "state": t.state})
    head = ("# Tags in the map frame: apriltag_ros standalone_tags (id, size m, name) plus\n"
            "# x y z (m), yaw (rad, outward normal), qw qx qy qz (upright marker), family,\n"
            "# covariance over (x, y, z, yaw) (m², m·rad, rad²), sightings, rejected,\n"
            "# first_seen_s / last_seen_s (stamps, s), state.\n")
    data = {"standalone_tags": entries, **({"resume_key": resume_key} if resume_key else {})}
    return head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None)


def _number(entry: dict, key: str, where: str) -> float:
    if key not in entry:
        raise ValueError(f"{where}: missing key '{key}'")
    v = entry[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{where}: key '{key}' must be a finite number, got {v!r}")
    return float(v)


def _integer(entry: dict, key: str, where: str, least: int) -> int:
    v = entry.get(key)
    if isinstance(v, bool) or not isinstance(v, int) or v < least:
        raise ValueError(f"{where}: key '{key}' must be an integer >= {least}, got {v!r}")
    return v


def _track(entry, where: str) -> TagTrack:
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: expected a mapping, got {entry!r}")
    tag_id = _integer(entry, "id", where, 0)
    where = f"{where} (id {tag_id})"
    size = _number(entry, "size", where)
    if size <= 0:
        raise ValueError(f"{where}: key 'size' must be > 0, got {size!r}")
    if not isinstance(entry.get("name", ""), str):
        raise ValueError(f"{where}: key 'name' must be a string, got {entry['name']!r}")
    if "family" not in entry:
        raise ValueError(f"{where}: missing key 'family'")
    try:
        family = canonical(entry["family"])
    except ValueError as exc:
        raise ValueError(f"{where}: key 'family': {exc}") from None
    mean = tuple(_number(entry, k, where) for k in ("x", "y", "z", "yaw"))
    q = np.array([_number(entry, k, where) for k in ("qw", "qx", "qy", "qz")])
    if abs(abs(q @ upright_quaternion(mean[3])) - 1.0) > 1e-9:
        raise ValueError(f"{where}: keys 'qw qx qy qz' are not an upright marker at 'yaw' "
                         f"{mean[3]!r}")
    cov = entry.get("covariance")
    try:
        C = np.array(cov, dtype=float)
    except (TypeError, ValueError):
        C = None
    if (C is None or C.shape != (4, 4) or not np.all(np.isfinite(C)) or not np.array_equal(C, C.T)
            or np.linalg.eigvalsh(C).min() < -1e-12):
        raise ValueError(f"{where}: key 'covariance' must be a symmetric positive "
                         f"semi-definite 4x4 list of lists, got {cov!r}")
    if entry.get("state") not in STATES:
        raise ValueError(f"{where}: key 'state' must be one of {STATES}, got "
                         f"{entry.get('state')!r}")
    return TagTrack(family, tag_id, size, mean, tuple(tuple(float(v) for v in row) for row in C),
                    _integer(entry, "sightings", where, 1), _integer(entry, "rejected", where, 0),
                    _number(entry, "first_seen_s", where), _number(entry, "last_seen_s", where),
                    entry["state"])


def load_tags_yaml(text: str) -> List[TagTrack]:
    """The tracks of a file ``to_standalone_tags_yaml`` wrote; ValueError naming the entry and
    the key on anything else (a plain apriltag_ros file lacks the map pose: refused)."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"tags file: not valid YAML: {exc}") from None
    if not isinstance(data, dict) or not isinstance(data.get("standalone_tags"), list):
        raise ValueError("tags file: expected a mapping with a 'standalone_tags' list")
    where = [f"standalone_tags[{i}]" for i in range(len(data["standalone_tags"]))]
    tracks = [_track(entry, here) for entry, here in zip(data["standalone_tags"], where)]
    _check_ids([(t.family, t.id, t.size_m) for t in tracks], where)
    return tracks


def resumable_tracks(text: str, resume_key: str):
    """The tracks of a tags.yaml written under ``resume_key`` (a tracker of the same launch that
    died), or None when it is another run's (or has no key). ValueError as ``load_tags_yaml``."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"tags file: not valid YAML: {exc}") from None
    if not resume_key or not isinstance(data, dict) or data.get("resume_key") != resume_key:
        return None
    return load_tags_yaml(text)


def to_csv(tracks: Sequence[TagTrack]) -> str:
    """One line per track under CSV_HEADER (m, rad, m², rad²); the x-y block and the z and yaw
    variances are what a 2D map view and an error report need."""
    lines = [CSV_HEADER]
    for t in tracks:
        C = t.covariance
        values = (*t.mean, C[0][0], C[0][1], C[1][1], C[2][2], C[3][3])
        lines.append(",".join([str(t.id), t.family, *(repr(v) for v in values), str(t.sightings)]))
    return "\n".join(lines) + "\n"
