"""Graph SLAM (ROS-free): keyframes from odometry, scans matched in C++, poses optimised by
GTSAM's iSAM2.

One ``Slam`` object takes plain data: wheel-odometry poses (the odom frame) and IMU yaw rates as
they come, scans as points in the base frame with the odometry pose at their stamp, tags as
positions in the base frame with the odometry pose at their image's stamp (``add_tag``). Every
``keyframe_distance_m`` or ``keyframe_angle_rad`` of odometry a scan becomes a keyframe, tied to
the one before it by two factors:

* wheel odometry, with a covariance from the wheel-slip model the simulator uses (variance per
  wheel grows with the distance it rolls);
* the scan matched against the local submap (the last keyframes' points at their current
  estimates), with the matcher's Hessian covariance; along a corridor's degenerate direction
  the matcher inflates it, so odometry takes over there;
* with a gyro (seed 000 names the IMU as its missing piece), its yaw rate integrated over the
  step, in a yaw-rate factor on the two poses, the gyro's bias (``B(m)``, a variable at a
  keyframe every ``gyro_bias_period_s``, a random walk from each to the next, the steps between
  sharing the newest: ``graph.add_bias``, ``add_yaw_rate``) and its scale error (``K(0)``, one
  for the run: ``graph.add_gyro_scale``). The gyro integrates (1 + k) (theta_j - theta_i) + b dt,
  and every step shares k and b: a bias left to each step's variance leaked into the heading
  (+0.05 rad over 2,500 s in the simulator), fitted outside the graph it was too weakly observed
  to subtract, and a scale fitted outside the graph left the turns made before it was known
  uncorrected (a house's map turned 2-5 mrad in its first minute). The gyro
  enters the graph there only: the odometry factor keeps the wheels' heading and variance, and
  the gyro's turn fused into the wheels' step (inverse-variance weights, the bias estimate
  subtracted) is only the prediction that seeds the scan match and gates it.

Loop closures: past keyframes whose estimate lies within the current pose's uncertainty
(3 sigma of its marginal, at least ``loop_radius_min_m``) are tried, nearest first; the scan is
matched against a submap around the candidate with a wider window, accepted above a score and
when the correction it makes is within the two poses' uncertainty (``match_gate_chi2`` on the
sum of their marginals and the match's covariance: in a maze whose corridors repeat every metre,
the window also holds the match one corridor over, which scores as well), and added with a
robust kernel (the graph's), so one wrong closure cannot wreck the map. A match that is degenerate (a
corridor) is a closure too: it fixes the heading and the position across the corridor, and its
covariance (degenerate_std_m along it) leaves the position along it to the rest of the graph; a
corridor driven twice otherwise keeps both passes apart (the MIT CSAIL log: 169 of 505 loop
matches were degenerate).

The map frame is the odom frame as it was when the first scan came (the start pose):
``map_to_odom`` is the identity until the first correction.

Real logs (issue 31), what the graph is protected from:

* stale odometry: a base's odometry can repeat one pose for several scans and then catch up
  (the MIT CSAIL log: up to 1 s). Odometry is judged to have jumped from the time its previous
  value was first seen, not from the previous scan (``OdometryWatch``), and never over less
  than the scan period (a log whose stamps bunch scans 1 ms apart);
* a real jump (a glitch, a base restart): the step across it is replaced by the step before it
  (constant velocity) with that step's size as its std, the later odometry rebased onto it; no
  loose tie that would leave the graph nearly indeterminate behind it;
* a step whose duration is zero or negative (stamps out of order) has no gyro samples: its
  heading is the wheels', never a zero-variance gyro's;
* a scan with no return on any beam is counted and skipped;
* should iSAM2 still refuse a step (``PoseGraph.update`` raises ValueError, the graph intact),
  the keyframe is kept on its odometry alone, or, refused again, dropped; one line each.
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import between, compose, inverse, transform_points, wrap_angle
from .graph import GraphSettings, PoseGraph
from .scan_matching import MatcherSettings, ScanMatcher

MAX_PLAUSIBLE_SPEED_MPS = 2.0     # odometry moving faster than this between scans jumped
MAX_PLAUSIBLE_TURN_RADPS = 10.0   # (a teleport, a reset to zero when the base restarts)
MAX_ODOMETRY_STALL_S = 2.0        # odometry repeating one pose is credited this long at most as a
                                  # stalled driver catching up (longer: a robot standing still)
SCAN_PERIODS_KEPT = 50            # scan intervals the scan period's median is taken over


@dataclass(frozen=True)
class SlamSettings:
    """slam node parameters (config/slam.yaml). Units in the names."""
    keyframe_distance_m: float = 0.25     # a new keyframe after this much travel ...
    keyframe_angle_rad: float = 0.26      # ... or this much turning (15 degrees)
    submap_keyframes: int = 12            # local submap: the last N keyframes' points
    # odometry noise model: each wheel's travel error has std slip * sqrt(distance it rolled)
    odom_slip_std_sqrt_m: float = 0.03    # m / sqrt(m)
    odom_floor_std_m: float = 0.005       # m, added to x and y of every step
    odom_floor_std_rad: float = 0.005     # rad, added to the heading of every step
    odom_turn_std_m_per_rad: float = 0.15  # m per rad turned, added to x and y where the laser's
                                          # mounting is unknown (a log whose laser pose is its
                                          # odometry pose: 0.1-0.16 m measured on two; add_scan)
    odom_timing_std_s: float = 0.05       # s, std of the time between a scan and the odometry pose
                                          # given for it (a driver's latency, unsynchronised clocks):
                                          # each end of a step is off by its velocity times this
    use_imu: bool = True                  # the gyro's yaw rate in the graph (yaw-rate factors)
    gyro_noise_std_radps: float = 0.002   # per IMU sample (the robot YAML's figure)
    gyro_bias_std_radps: float = 0.001    # prior std of the gyro's bias at the first keyframe
    gyro_bias_walk_radps_per_sqrt_s: float = 1e-6   # its random walk: std of the change over t s
                                          # is this * sqrt(t)
    gyro_bias_period_s: float = 60.0      # a new bias variable at the first keyframe this long after
                                          # the last one's (0: one per keyframe); the steps between
                                          # share it. One per keyframe doubled the cliques iSAM2
                                          # re-eliminates at a loop closure: a recorded 1,200 s house
                                          # drive's p99 14 -> 47 ms CPU; every 60 s, 17 ms, the same
                                          # heading error (the bias walks ~8e-6 rad/s in 60 s); the
                                          # office drive: 7 -> 3.5 ms per keyframe, 30 ms every 60 s
    gyro_scale_std: float = 0.02          # prior std of the scale factor error (fraction), in the graph
    match_min_score: float = 0.5          # scan-match factors below this score are left out
    match_gate_chi2: float = 16.3         # ... and those this far (Mahalanobis^2 over both
                                          # covariances) from odometry's prediction: a corridor's
                                          # repeated door frames can pull a match a frame's width
                                          # along it with a confident covariance (99.9 %, 3 dof)
    loop_every_keyframes: int = 2         # search for a loop closure every N keyframes
    loop_min_gap_keyframes: int = 30      # candidates at least this many keyframes back
    loop_radius_min_m: float = 1.0        # search radius floor (m) ...
    loop_radius_max_m: float = 4.0        # ... and cap (m)
    loop_submap_half_keyframes: int = 6   # candidate's submap: keyframes j-N .. j+N
    loop_min_score: float = 0.5           # accept a closure at or above this match score
    loop_max_candidates: int = 2          # matches tried per search
    loop_search_xy_m: float = 1.0         # a loop closure's correlative window: half-width (m) ...
    loop_search_yaw_rad: float = 0.5      # ... and in yaw (rad); the rest as matcher's
    matcher: MatcherSettings = field(default_factory=MatcherSettings)
    graph: GraphSettings = field(default_factory=GraphSettings)

    def validate(self, src: str) -> None:
        require(self.odom_turn_std_m_per_rad >= 0, src, "odom_turn_std_m_per_rad", "must be >= 0")
        require(self.odom_timing_std_s >= 0, src, "odom_timing_std_s", "must be >= 0")
        positive(src, self, "keyframe_distance_m", "keyframe_angle_rad", "submap_keyframes", "match_gate_chi2",
                 "odom_slip_std_sqrt_m", "odom_floor_std_m", "odom_floor_std_rad", "loop_every_keyframes",
                 "loop_min_gap_keyframes", "loop_radius_min_m", "loop_radius_max_m",
                 "loop_submap_half_keyframes", "loop_max_candidates", "loop_search_xy_m", "loop_search_yaw_rad")
        require(self.loop_radius_min_m <= self.loop_radius_max_m, src, "loop_radius_min_m",
                "must be <= loop_radius_max_m")
        for key in ("match_min_score", "loop_min_score"):
            require(0.0 <= getattr(self, key) <= 1.0, src, key, "must be in [0, 1]")
        positive(src, self, "gyro_noise_std_radps", "gyro_bias_std_radps", "gyro_bias_walk_radps_per_sqrt_s",
                 "gyro_scale_std")
        require(self.gyro_bias_period_s >= 0, src, "gyro_bias_period_s", "must be >= 0 (0: one per keyframe)")


@dataclass(frozen=True)
class GyroStep:
    """The gyro over one keyframe step: its rate integrated over the step (rad, as it reads:
    scale error and bias in it), the step's duration and the variance of the white noise in the
    integral (rad^2)."""
    raw_rad: float
    span_s: float
    var_white_rad2: float


@dataclass
class Keyframe:
    stamp_s: float
    odom: np.ndarray          # (3,) odometry pose at the scan (odom frame)
    points: np.ndarray        # (n, 2) scan points in the base frame
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))   # odometry's (vx, vy, yaw rate), body frame


def odometry_covariance(delta, separation_m: float, s: SlamSettings, lever: bool = True) -> np.ndarray:
    """The covariance of an odometry step ``delta`` (x, y, yaw in the first pose's frame) from
    the wheel-slip model: each wheel's travel error has variance slip^2 * |its travel|, so
    forward travel d and turn a give var(d) = (vl + vr) / 4, var(a) = (vl + vr) / B^2 and
    cov(d, a) = (vr - vl) / (2B); the heading error then swings the end point sideways
    (var(y) ~ d^2 var(a) / 3 for a heading error growing along the step: d / 2 times the end
    heading's error, plus d^2 var(a) / 12 of its own), and the travel error, correlated with the
    turn's, with it: cov(x, y) = d cov(d, a) / 2. So the covariance is J S J^T + diag(0, d^2
    var(a) / 12, 0), S the (d, a) covariance: positive semi-definite for any step (without the
    x-y term, a step that turns while it travels, 0.9 m and 0.9 rad, had a negative
    eigenvalue). Floors are added, and (odom_turn_std_m_per_rad * a)^2 to x and y: a turn in
    place moves a scan frame that sits off the turning centre by a chord of that lever (with
    ``lever``; without, for the base frame itself)."""
    d = math.hypot(delta[0], delta[1])
    a = float(delta[2])
    half = 0.5 * separation_m * a
    vl = s.odom_slip_std_sqrt_m ** 2 * abs(d - half)
    vr = s.odom_slip_std_sqrt_m ** 2 * abs(d + half)
    var_d = 0.25 * (vl + vr)
    var_a = (vl + vr) / separation_m ** 2
    cov_da = (vr - vl) / (2.0 * separation_m)
    cov = np.array([[var_d, 0.5 * d * cov_da, cov_da],
                    [0.5 * d * cov_da, d * d * var_a / 3.0, 0.5 * d * var_a],
                    [cov_da, 0.5 * d * var_a, var_a]])
    chord = (s.odom_turn_std_m_per_rad * a) ** 2 if lever else 0.0
    return cov + np.diag([s.odom_floor_std_m ** 2 + chord, s.odom_floor_std_m ** 2 + chord, s.odom_floor_std_rad ** 2])


def timing_covariance(delta, velocity_start, velocity_end, timing_std_s: float) -> np.ndarray:
    """The covariance an odometry step ``delta`` (x, y, yaw in its first pose's frame) gains
    when the odometry pose given with a scan is the robot's pose at a time off by std
    ``timing_std_s``, independently at both ends: each end is displaced along its own velocity
    (vx, vy, yaw rate in that pose's body frame), (v dt, w dt), so the step's covariance gains
    tau^2 (a a^T + b b^T), a and b the two velocities in the first pose's frame. A log whose
    odometry and laser clocks drift apart (the MIT CSAIL log: per 0.21 s scan interval, the
    odometry's turn is off by 1.0 deg at 0-5 deg/s and 4-6 deg above 30 deg/s, its travel by
    6 mm standing and 5 cm at 1 m/s, against a constant 0.4-0.8 deg and 6-7 mm on the Intel
    Lab's) has errors that grow with the speed, which no constant floor models."""
    c, s = math.cos(delta[2]), math.sin(delta[2])
    a = np.asarray(velocity_start, float)
    ve = np.asarray(velocity_end, float)
    b = np.array([c * ve[0] - s * ve[1], s * ve[0] + c * ve[1], ve[2]])
    return timing_std_s ** 2 * (np.outer(a, a) + np.outer(b, b))


class OdometryWatch:
    """Whether each scan's odometry pose jumped from the previous scan's: a step faster than
    MAX_PLAUSIBLE_SPEED_MPS / MAX_PLAUSIBLE_TURN_RADPS over the time since the previous pose was
    first seen (a stalled driver repeats it, then catches up; credited up to
    MAX_ODOMETRY_STALL_S), and never over less than the median scan period (stamps that bunch
    or go back)."""

    def __init__(self):
        self.last: Optional[tuple] = None      # (stamp first seen, pose) of the current odometry value
        self.last_stamp_s: Optional[float] = None
        self.periods: deque = deque(maxlen=SCAN_PERIODS_KEPT)
        self.step = np.zeros(3)                # the last plausible step, over one scan period (body frame)

    def period_s(self) -> float:
        return float(np.median(self.periods)) if self.periods else 1e-3

    def velocity(self) -> np.ndarray:
        """The odometry's last plausible velocity (vx, vy, yaw rate; m/s, rad/s, body frame)."""
        return self.step / self.period_s() if self.periods else np.zeros(3)

    def jumped(self, stamp_s: float, odom: np.ndarray) -> bool:
        if self.last_stamp_s is not None and stamp_s > self.last_stamp_s:
            self.periods.append(stamp_s - self.last_stamp_s)
        self.last_stamp_s = stamp_s
        if self.last is None:
            self.last = (stamp_s, odom)
            return False
        t0, p0 = self.last
        if np.array_equal(p0, odom):
            return False
        self.last = (stamp_s, odom)
        d = between(p0, odom)
        dt = max(min(stamp_s - t0, MAX_ODOMETRY_STALL_S), self.period_s())
        if math.hypot(d[0], d[1]) > MAX_PLAUSIBLE_SPEED_MPS * dt + 0.05 \
                or abs(d[2]) > MAX_PLAUSIBLE_TURN_RADPS * dt + 0.1:
            return True
        self.step = d * min(1.0, self.period_s() / max(stamp_s - t0, 1e-9))   # a catch-up: its share of a period
        return False


class Slam:
    def __init__(self, settings: SlamSettings, wheel_separation_m: float):
        self.s = settings
        self.separation = wheel_separation_m
        self.matcher = ScanMatcher(settings.matcher)
        self.loop_matcher = ScanMatcher(dataclasses.replace(
            settings.matcher, search_xy_m=settings.loop_search_xy_m, search_yaw_rad=settings.loop_search_yaw_rad))
        self.graph: Optional[PoseGraph] = None
        self.keyframes: list[Keyframe] = []
        self.estimates = np.zeros((0, 3))
        self.gyro: list[tuple] = []             # (stamp, yaw rate) since the last keyframe
        self.last_odom = None                   # (stamp, pose) of the last scan seen
        self.odom_watch = OdometryWatch()
        self._jump_var: Optional[np.ndarray] = None   # variance added to the step across a jump
        self._lever = False                     # the scan's mounting unknown (add_scan's mount_known)
        self.counts = dict(keyframes=0, matched=0, match_rejected=0, match_inconsistent=0, degenerate=0, loop_tried=0,
                           loop_accepted=0, loop_inconsistent=0, odom_jumps=0, resets=0, imu_fused=0,
                           scans_no_return=0, refused=0, keyframes_dropped=0)
        self.update_ms: list[float] = []
        self.match_ms: list[float] = []
        self.events: list[str] = []             # one line per thing a caller should log once

    # ------------------------------------------------------------------ inputs
    def reset(self, why: str) -> None:
        """Forget everything (time went backwards: a looping bag, a restarted simulation)."""
        self.graph = None
        self.keyframes.clear()
        self.estimates = np.zeros((0, 3))
        self.gyro.clear()
        self.last_odom = None
        self.odom_watch = OdometryWatch()
        self._jump_var = None
        self.counts["resets"] += 1
        self.events.append(f"state cleared: {why}")

    def add_imu(self, stamp_s: float, yaw_rate_radps: float) -> None:
        if math.isfinite(yaw_rate_radps):
            self.gyro.append((float(stamp_s), float(yaw_rate_radps)))

    def add_scan(self, stamp_s: float, points_base: np.ndarray, odom_pose, mount_known: bool = True) -> bool:
        """A scan (points in the base frame, (n, 2)) with the odometry pose at its stamp.
        Returns whether it became a keyframe (the graph was updated then). A scan without a
        point (no return on any beam) is counted and left out. ``mount_known``: the points are
        in the base frame exactly (the laser's mounting from TF or the robot's YAML); False for
        a log that gives its laser's pose as the odometry's, where a turn moves the scan frame
        by an unknown lever (``odom_turn_std_m_per_rad`` enters the odometry steps then)."""
        self._lever = not mount_known
        odom = np.asarray(odom_pose, float)
        if not np.isfinite(odom).all():
            self.events.append(f"odometry pose not finite {odom.tolist()}: scan at {stamp_s:.2f} s skipped")
            return False
        jumped = self.odom_watch.jumped(stamp_s, odom)
        previous, self.last_odom = self.last_odom, (stamp_s, odom)
        points_base = np.asarray(points_base, float).reshape(-1, 2)
        if self.graph is None:
            if not len(points_base):
                self.counts["scans_no_return"] += 1
                return False
            # the map frame is the odom frame as it was at the start: the first keyframe sits at
            # its odometry pose (map -> odom starts as the identity)
            self.graph = PoseGraph(self.s.graph, first_pose=tuple(odom))
            self._store(stamp_s, odom, points_base, odom.copy())
            self._integrate_gyro(stamp_s, stamp_s)      # drop the samples before it
            return True
        last = self.keyframes[-1]
        if jumped:
            self._rebase(previous[1], odom)
            self.events.append(f"odometry jumped to ({odom[0]:.2f}, {odom[1]:.2f}, {odom[2]:.2f}) at {stamp_s:.2f} s: "
                               f"the step before it stands in for the step across it")
        if not len(points_base):
            self.counts["scans_no_return"] += 1
            return False
        delta = between(last.odom, odom)
        if math.hypot(delta[0], delta[1]) < self.s.keyframe_distance_m and abs(delta[2]) < self.s.keyframe_angle_rad:
            return False
        return self._keyframe(stamp_s, odom, points_base, delta)

    def _rebase(self, before: np.ndarray, odom: np.ndarray) -> None:
        """The odometry jumped from ``before`` (the previous scan's) to ``odom``: assume the robot
        made the last plausible step in between (constant velocity) and move the last keyframe's
        odometry pose into the new odometry frame accordingly; the next keyframe's step gets that
        step's size as extra std (floored)."""
        self.counts["odom_jumps"] += 1
        step = self.odom_watch.step
        correction = compose(odom, inverse(compose(before, step)))   # old odom frame -> new
        last = self.keyframes[-1]
        last.odom = compose(correction, last.odom)
        d = max(math.hypot(step[0], step[1]), self.s.odom_floor_std_m)
        a = max(abs(step[2]), self.s.odom_floor_std_rad)
        var = np.array([d * d, d * d, a * a])
        self._jump_var = var if self._jump_var is None else self._jump_var + var

    def add_tag(self, stamp_s: float, name: str, xy_base, covariance_xy, odom_pose) -> Optional[str]:
        """A tag seen at ``xy_base`` (m, base frame) with its 2x2 covariance in the image taken at
        ``stamp_s``, when odometry put the base at ``odom_pose`` (odom frame: the node looks it
        up at the image's stamp). It is tied to the keyframe nearest in time through the
        odometry step from that keyframe's pose to ``odom_pose`` (from the last keyframe, the
        step's heading fused with the gyro's turn as a keyframe step's is), the step's
        covariance carried into the sighting's. Returns a reason if it was not used.

        The pose at the image's stamp, not the newest scan's: scans and images are not
        synchronised, and a detection reaches the node after the detector's latency (up to 1 s
        seen on a loaded machine), scans and keyframes having come meanwhile: the newest scan's
        pose had turned up to 0.6 rad from the image's in a house run (docs/benchmarks.md)."""
        if not self.keyframes or self.last_odom is None:
            return "no keyframe yet"
        if stamp_s < self.keyframes[0].stamp_s:
            return f"seen at {stamp_s:.2f} s, before the first keyframe ({self.keyframes[0].stamp_s:.2f} s)"
        odom = np.asarray(odom_pose, float)
        if odom.shape != (3,) or not np.isfinite(odom).all():
            return f"the odometry pose at the tag's stamp must be 3 finite numbers, got {odom_pose!r}"
        key = self._keyframe_near(stamp_s)
        rel, rel_cov = self._step_to(key, stamp_s, between(self.keyframes[key].odom, odom))
        xy_obs = np.array([float(xy_base[0]), float(xy_base[1])])
        c, s = math.cos(rel[2]), math.sin(rel[2])
        R = np.array([[c, -s], [s, c]])
        xy = rel[:2] + R @ xy_obs
        # the sighting in the keyframe's frame: d xy = d t + d theta R (-y, x) + R d xy_obs
        J = np.column_stack([np.eye(2), R @ np.array([-xy_obs[1], xy_obs[0]])])
        try:
            cov = R @ np.asarray(covariance_xy, float) @ R.T + J @ rel_cov @ J.T
            return self.graph.add_landmark(name, key, xy, cov)
        except ValueError as exc:       # NaN, a covariance that is not one: refused, graph untouched
            return str(exc)

    def _keyframe_near(self, stamp_s: float) -> int:
        """The keyframe whose stamp is nearest ``stamp_s`` (the newest ones first: a tag is
        seen within a few keyframes of the last)."""
        best = len(self.keyframes) - 1
        for k in range(len(self.keyframes) - 1, -1, -1):
            if abs(self.keyframes[k].stamp_s - stamp_s) <= abs(self.keyframes[best].stamp_s - stamp_s):
                best = k
            if self.keyframes[k].stamp_s <= stamp_s:
                break
        return best

    def _step_to(self, key: int, stamp_s: float, rel: np.ndarray) -> tuple:
        """The odometry step ``rel`` from keyframe ``key`` to ``stamp_s`` and its covariance: the
        wheels' model without the lever term (that moves a scan frame off the turning centre;
        the base frame turns on it); from the last keyframe forward in time, its heading fused
        with the gyro's turn (``_predict``; the samples are read, not consumed: those before the
        last keyframe are gone)."""
        cov = odometry_covariance(rel, self.separation, self.s, lever=False)
        t0 = self.keyframes[key].stamp_s
        if key != len(self.keyframes) - 1 or stamp_s <= t0:
            return rel, cov
        gyro = self._gyro_step(t0, stamp_s, *self._integrate_gyro(t0, stamp_s, consume=False))
        return self._predict(rel, cov, gyro)

    # ------------------------------------------------------------------ outputs
    def map_to_odom(self) -> np.ndarray:
        """The map -> odom transform (x, y, yaw) implied by the newest keyframe."""
        if not self.keyframes:
            return np.zeros(3)
        return compose(self.estimates[-1], inverse(self.keyframes[-1].odom))

    def pose(self, odom_pose) -> np.ndarray:
        """The map pose of the base given its odometry pose."""
        return compose(self.map_to_odom(), odom_pose)

    def stats(self) -> dict:
        out = dict(self.counts)
        for name, values in (("isam2_ms", self.update_ms), ("scan_match_ms", self.match_ms)):
            if values:
                v = np.asarray(values)
                out[f"{name}_median"] = float(np.median(v))
                out[f"{name}_p99"] = float(np.percentile(v, 99))
                out[f"{name}_max"] = float(v.max())
        scale = self.graph.gyro_scale() if self.graph is not None else None
        if scale is not None:    # the gyro's variables, once through iSAM2
            last = self.graph.last_bias()
            out["gyro_bias_radps"], out["gyro_bias_std_radps"] = self.graph.bias(last), self.graph.bias_std(last)
            out["gyro_scale"], out["gyro_scale_std"] = scale
        if self.graph is not None:     # tag landmarks: in the graph, sightings used, refused by the gate
            lm = self.graph.landmark_stats()
            out.update(landmarks=lm["landmarks"], landmark_sightings=lm["sightings"],
                       landmark_rejected=lm["rejected"])
        tried = self.counts["loop_tried"]
        out["loop_acceptance_rate"] = self.counts["loop_accepted"] / tried if tried else None
        return out

    def take_events(self) -> list:
        events, self.events = self.events, []
        return events

    # ------------------------------------------------------------------ internals
    def _store(self, stamp_s, odom, points, estimate) -> None:
        self.keyframes.append(Keyframe(float(stamp_s), odom.copy(), np.asarray(points, float).reshape(-1, 2),
                                       self.odom_watch.velocity()))
        self.estimates = np.vstack([self.estimates, estimate])
        self.counts["keyframes"] += 1

    def _odometry(self, stamp_s: float, delta: np.ndarray) -> tuple:
        """The wheels' covariance of the odometry step ``delta`` to ``stamp_s`` (the graph's
        odometry factor) and the gyro over it (a ``GyroStep``, or None)."""
        cov = odometry_covariance(delta, self.separation, self.s, lever=self._lever)
        if self.s.odom_timing_std_s > 0:
            cov = cov + timing_covariance(delta, self.keyframes[-1].velocity, self.odom_watch.velocity(),
                                          self.s.odom_timing_std_s)
        t0 = self.keyframes[-1].stamp_s
        return cov, self._gyro_step(t0, stamp_s, *self._integrate_gyro(t0, stamp_s))

    def _gyro_step(self, t0: float, t1: float, raw: float, covered: float, samples: int) -> Optional[GyroStep]:
        """The gyro over (t0, t1] (``_integrate_gyro``'s figures) as a ``GyroStep``; None
        where it measured no turn."""
        span = t1 - t0
        if not self.s.use_imu or samples == 0 or span <= 0.0 or covered < span - 1e-6:
            # a gap in the gyro's samples, or a step of no duration (stamps out of order): no gyro
            # sample measured its turn, wheel odometry alone
            return None
        period = covered / max(1, samples)
        # white noise per sample over span / period samples
        return GyroStep(raw, span, self.s.gyro_noise_std_radps ** 2 * period * span)

    def _gyro_turn(self, gyro: GyroStep) -> tuple:
        """The true turn the gyro's step measures, the graph's estimates of its bias (the newest
        variable's) taken out and divided by 1 + its scale error, and that turn's variance from
        the white noise and the scale's uncertainty (its prior's before the graph has it)."""
        m, scale = self.graph.last_bias(), self.graph.gyro_scale()
        k, k_std = scale if scale is not None else (0.0, self.s.gyro_scale_std)
        turn = (gyro.raw_rad - (self.graph.bias(m) * gyro.span_s if m is not None else 0.0)) / (1.0 + k)
        return turn, gyro.var_white_rad2 + (k_std * turn) ** 2

    def _predict(self, delta: np.ndarray, cov: np.ndarray, gyro: Optional[GyroStep]) -> tuple:
        """The step predicted from the wheels and the gyro (the scan match's guess and gate): the
        gyro's turn fused into the heading by inverse-variance weights, the bias's own uncertainty
        (``gyro_bias_std_radps`` over the step) on top of its variance; and its covariance."""
        if gyro is None:
            return delta, cov
        turn, var_turn = self._gyro_turn(gyro)
        var_imu = var_turn + (self.s.gyro_bias_std_radps * gyro.span_s) ** 2
        var_odo = cov[2, 2]
        gain = var_odo / (var_odo + var_imu) if var_odo + var_imu > 0 else 0.0
        fused = delta.copy()
        fused[2] = delta[2] + gain * wrap_angle(turn - delta[2])
        # the heading's variance shrinks; its correlation with x, y shrinks in proportion
        cov = cov.copy()
        cov[2, :2] *= (1.0 - gain)
        cov[:2, 2] *= (1.0 - gain)
        cov[2, 2] = (1.0 - gain) * var_odo
        return fused, cov

    def _add_gyro(self, i: int, j: int, stamp_s: float, gyro: Optional[GyroStep]) -> None:
        """Queue the gyro's part of step i -> j (keyframe j at ``stamp_s``): the yaw-rate factor
        when the gyro measured the step, on the newest bias variable, and a new bias variable at
        j, a random walk from that one, once it is ``gyro_bias_period_s`` old (the first bias,
        at i, under its prior). Before the gyro's first step nothing (a log without a gyro: no
        bias at all)."""
        m = self.graph.last_bias()
        if m is None:
            if gyro is None:
                return
            self.graph.add_bias(i, prior_std=self.s.gyro_bias_std_radps)
            self.graph.add_gyro_scale(self.s.gyro_scale_std)
            m = i
        if gyro is not None:
            self.graph.add_yaw_rate(i, j, gyro.raw_rad, gyro.span_s, math.sqrt(gyro.var_white_rad2), bias_key=m)
        age = stamp_s - self.keyframes[m].stamp_s
        if age >= self.s.gyro_bias_period_s:
            walk = self.s.gyro_bias_walk_radps_per_sqrt_s * math.sqrt(max(age, 1e-3))
            self.graph.add_bias(j, walk_from=m, walk_std=walk)
        self.counts["imu_fused"] += int(gyro is not None)

    def _integrate_gyro(self, t0: float, t1: float, consume: bool = True) -> tuple:
        """The heading change over (t0, t1] from the gyro, the time its samples covered and how
        many samples contributed: each
        sample is the mean rate over the interval since the one before it, so the integral is
        exact however the samples fall against t0 and t1. With ``consume``, samples before t1
        are dropped, but the last one (it opens the next interval)."""
        g = self.gyro
        yaw = covered = 0.0
        samples = 0
        # a sample stands for one period before it, not for a gap in the stream (a stalled
        # driver): the gap stays uncovered, and the step falls back on wheel odometry
        period = float(np.median(np.diff([t for t, _ in g]))) if len(g) > 2 else math.inf
        for (ta, _), (tb, w) in zip(g, g[1:]):
            overlap = min(tb, t1) - max(ta, tb - 1.5 * period, t0)
            if overlap > 0.0:
                yaw += w * overlap
                covered += overlap
                samples += 1
        if g and samples and g[-1][0] < t1:
            # the samples up to t1 are not all in yet (the IMU messages of the scan's own instant
            # often come just after the scan): the last rate holds for the rest, three periods at most
            tail = t1 - max(g[-1][0], t0)
            if tail <= 3.0 * covered / samples:
                yaw += g[-1][1] * tail
                covered += tail
        if consume:
            keep = max((i for i, (t, _) in enumerate(g) if t <= t1), default=0)
            self.gyro = g[keep:]
        return yaw, covered, samples

    def _submap(self, lo: int, hi: int) -> tuple:
        """The points of keyframes lo..hi-1 in the map frame, at their current estimates, and
        where each was seen from (its keyframe's position): (m, 2) each, for the matcher's
        ``views``."""
        kept = [i for i in range(lo, hi) if len(self.keyframes[i].points)]
        if not kept:
            return np.zeros((0, 2)), np.zeros((0, 2))
        points = np.vstack([transform_points(self.estimates[i], self.keyframes[i].points) for i in kept])
        views = np.repeat(self.estimates[kept, :2], [len(self.keyframes[i].points) for i in kept], axis=0)
        return points, views

    def _keyframe(self, stamp_s: float, odom: np.ndarray, points: np.ndarray, delta: np.ndarray) -> bool:
        """A keyframe at this scan; whether it was kept (``_update``)."""
        prev = len(self.keyframes) - 1
        cov, gyro = self._odometry(stamp_s, delta)
        jumped = self._jump_var is not None
        if jumped:               # the step spans an odometry jump: as uncertain as the step stood in
            cov = cov + np.diag(self._jump_var)
            self._jump_var = None
        odometry = (prev, delta, cov)
        factors = [odometry]
        step, step_cov = self._predict(delta, cov, gyro)
        guess = compose(self.estimates[prev], step)
        reference, views = self._submap(max(0, prev + 1 - self.s.submap_keyframes), prev + 1)
        t0 = time.perf_counter()
        match = self.matcher.match(points, reference, guess, views)
        self.match_ms.append(1e3 * (time.perf_counter() - t0))
        if match is not None and match.score >= self.s.match_min_score:
            if self._consistent(guess, step_cov, match):
                factors.append((prev, between(self.estimates[prev], match.pose), match.covariance))
                self.counts["matched"] += 1
                self.counts["degenerate"] += int(match.degenerate)
                guess = match.pose
            else:
                self.counts["match_inconsistent"] += 1
        else:
            self.counts["match_rejected"] += 1
        key = self.graph.add_keyframe(guess, factors)
        assert key == prev + 1, (key, prev)
        self._add_gyro(prev, key, stamp_s, gyro)
        self._store(stamp_s, odom, points, guess)
        if key % self.s.loop_every_keyframes == 0:
            self._close_loop(key)
        return self._update(key, odometry, step, lambda: self._add_gyro(prev, key, stamp_s, gyro))

    def _update(self, key: int, odometry: tuple, step: np.ndarray, add_gyro) -> bool:
        """iSAM2 with keyframe ``key``'s factors (and a loop closure's). Refused (the graph is left
        as it was before them), the keyframe is tied by its ``odometry`` factor and the gyro
        (``add_gyro()`` queues its part again) alone, at the predicted ``step``; refused again,
        it is dropped (the next scan makes a new one). One line each."""
        try:
            self.update_ms.append(self.graph.update())
        except ValueError as exc:
            self.counts["refused"] += 1
            self.events.append(f"keyframe {key}: {exc}; kept on its odometry alone")
            guess = compose(self.estimates[key - 1], step)
            try:
                self.graph.add_keyframe(guess, [odometry])
                add_gyro()
                self.update_ms.append(self.graph.update())
            except ValueError as again:
                self.counts["keyframes_dropped"] += 1
                self.counts["keyframes"] -= 1
                self.keyframes.pop()
                self.estimates = self.estimates[:key]
                self.events.append(f"keyframe {key}: {again}; dropped")
                return False
        self.estimates = self.graph.poses()
        return True

    def _consistent(self, predicted, step_cov: np.ndarray, match) -> bool:
        """Whether the match agrees with odometry's prediction within match_gate_chi2 (both in
        the new keyframe's body frame; the step's covariance is in the previous keyframe's,
        turned by the step's small rotation: close enough for a gate)."""
        return self._within_gate(between(predicted, match.pose), step_cov + match.covariance)

    def _within_gate(self, v: np.ndarray, S: np.ndarray) -> bool:
        """Whether the pose difference ``v`` lies within match_gate_chi2 (Mahalanobis^2) under
        the covariance ``S``; a singular ``S`` does not."""
        try:
            d2 = float(v @ np.linalg.solve(S, v))
        except np.linalg.LinAlgError:
            return False
        return d2 <= self.s.match_gate_chi2

    def _loop_consistent(self, j: int, key: int, match) -> bool:
        """Whether the correction a loop closure makes to the new keyframe's estimate lies within
        match_gate_chi2 of the uncertainty of it and of the candidate ``j`` (their marginals
        summed, the candidate's turned into the new keyframe's frame: conservative, as it leaves
        out their correlation) plus the match's own. The new keyframe has no marginal before the
        update: the one before it stands in."""
        here = self.estimates[key]
        try:
            s_key = self.graph.marginal(key - 1)
            s_j = self.graph.marginal(j)
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            return True     # no marginal yet: the score and the robust kernel decide
        turn = self.estimates[j][2] - here[2]
        c, s = math.cos(turn), math.sin(turn)
        r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return self._within_gate(between(here, match.pose), s_key + r @ s_j @ r.T + match.covariance)

    def _close_loop(self, key: int) -> None:
        first_candidate = key - self.s.loop_min_gap_keyframes
        if first_candidate <= 0:
            return
        here = self.estimates[key]
        try:
            cov = self.graph.marginal(key - 1)[:2, :2]
            sigma = math.sqrt(max(float(np.linalg.eigvalsh(cov).max()), 0.0))
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            sigma = 0.0
        radius = min(self.s.loop_radius_max_m, max(self.s.loop_radius_min_m, 3.0 * sigma))
        dist = np.hypot(*(self.estimates[:first_candidate, :2] - here[:2]).T)
        order = [int(j) for j in np.argsort(dist) if dist[j] <= radius]
        points = self.keyframes[key].points
        tried = 0
        for j in order:
            if tried >= self.s.loop_max_candidates:
                break
            tried += 1
            self.counts["loop_tried"] += 1
            h = self.s.loop_submap_half_keyframes
            reference, views = self._submap(max(0, j - h), min(first_candidate, j + h + 1))
            match = self.loop_matcher.match(points, reference, here, views)
            if match is None or match.score < self.s.loop_min_score:
                continue
            if math.hypot(*(match.pose[:2] - here[:2])) > radius:
                continue
            if not self._loop_consistent(j, key, match):
                self.counts["loop_inconsistent"] += 1
                continue
            self.graph.add_loop(j, key, between(self.estimates[j], match.pose), match.covariance)
            self.counts["loop_accepted"] += 1
            return
