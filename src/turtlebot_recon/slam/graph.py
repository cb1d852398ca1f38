"""The SLAM back end: a GTSAM iSAM2 pose graph over planar keyframes and tag landmarks.

Variables: keyframe poses ``X(k)`` (``gtsam.Pose2``, k = 0, 1, ... in the order they are
added), the gyro's bias ``B(k)`` at keyframe k (a double in mrad/s, ``BIAS_UNIT_RADPS``, at the
keyframes the caller gives one; every method takes and gives rad/s) and landmarks, numbered j = 0, 1, ... in the order they are first seen: ``L(j)``, a
``Point2``, for a tag seen as a position, ``T(j)``, a ``Pose2``, for a tag seen with its yaw (two
letters because iSAM2's relinearisation thresholds are per letter and per dimension). Factors,
as in GTSAM's Pose2 iSAM2 example:

1. a prior on ``X(0)`` (``GraphSettings.prior_std``);
2. between-factors ending at each new keyframe (odometry, scan matching), Gaussian;
3. loop closures, between-factors whose Gaussian is wrapped in a robust kernel (Cauchy or
   Huber, ``loop_kernel``), so one wrong closure cannot pull the map apart: a closure whose
   whitened error is many times the kernel width weighs almost nothing;
4. landmark sightings: ``BearingRangeFactor2D`` (position) or ``BetweenFactorPose2`` (pose),
   Gaussian; a landmark enters only with its second consistent sighting, so iSAM2 never meets an
   under-determined variable, and a sighting far outside the estimate's uncertainty is refused;
5. the gyro (``add_bias``, ``add_gyro_scale``, ``add_yaw_rate``): a prior on the first bias
   variable, a random walk ``BetweenFactorDouble`` from each bias to the next, one variable
   ``K(0)`` for the gyro's scale factor error k under a prior (a fraction, held in per mille:
   ``SCALE_UNIT``), and per keyframe step i -> j a yaw-rate factor on ``X(i)``, ``X(j)``, the
   bias ``B(m)`` the step has (``B(i)`` where each keyframe has one) and ``K(0)``: the gyro
   integrates ``(1 + k) (theta_j - theta_i) + b dt`` over the step, and the factor's error is
   that less its reading (a ``gtsam.CustomFactor``: GTSAM's ``AHRSFactor`` is the same idea for
   ``Rot3`` and a 3-vector bias, and does not fit a ``Pose2`` graph). Every step shares the bias
   and the scale, so the graph weighs the turns' common error as one, where independent
   odometry factors each took their share as their own; and a turn made before k was known is
   corrected by the turns after it (a scale fitted outside the graph left the first minute's
   turns in place: a house's whole map turned by 2-5 mrad).

Each ``add_*`` call queues factors and values; ``update`` hands everything queued to one
``ISAM2.update`` (a fresh ``new_factors`` / ``new_values`` per step) and returns its wall time.

Units and frames: metres and radians; poses and deltas are (x, y, yaw); a delta from key i to
key j is pose_i⁻¹ ∘ pose_j (``geometry.between``). Every 3x3 covariance is in GTSAM's Pose2
convention: (x, y, yaw) of a right perturbation, i.e. expressed in the frame of the measured
pose itself (``body_covariance`` converts one given in the parent frame). A landmark position
(x, y) and its 2x2 covariance are in the observing keyframe's base frame.

Bad input: a non-finite number, a wrong shape, a covariance that is not symmetric positive
definite or a key that does not exist raises ValueError naming it, before anything is queued,
so the graph is never corrupted and the next valid update works. Should ``ISAM2.update`` itself
fail (GTSAM's IndeterminateLinearSystemException, a RuntimeError in Python), the graph is
rebuilt from the factors it held before (a batch Levenberg-Marquardt from the last estimate) and
the step's new factors are dropped, with a one-line ValueError saying so.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, K, L, T, X

from ..config import positive, require
from ..geometry import wrap_angle

KERNELS = ("cauchy", "huber")
BIAS_UNIT_RADPS = 1e-3       # B(k) holds the gyro's bias in mrad/s: iSAM2's thresholds are
                             # absolute, and its wildfire (0.001) stops back-substitution at a
                             # change below it; in rad/s no bias change (~1e-4) ever passed it
                             # (the first keyframes' bias stayed 2e-4 rad/s off the last's). In
                             # mrad/s, 0.001 turns the heading by 1 mrad over 1,000 s
SCALE_UNIT = 1e-3            # K(0) holds the gyro's scale error in per mille, for the same reason
SCALE_RELINEARIZE = 1.0      # per mille: K(0)'s move that relinearises the yaw-rate factors (with the
                             # headings they multiply, off by < 5 mrad, a 1 per mille error in the
                             # Jacobian is 5e-6 rad)
MIN_LANDMARK_RANGE_M = 0.05   # a position sighting nearer than this has no usable bearing
                              # (tags are seen from 0.2 m and beyond)


@dataclass(frozen=True)
class GraphSettings:
    prior_std: Tuple[float, float, float] = (0.01, 0.01, 0.01)   # m, m, rad: prior on X(0)
    loop_kernel: str = "cauchy"          # cauchy | huber. Cauchy's influence falls to zero for
                                         # large errors (a 5 m wrong closure weighs ~1e-3);
                                         # Huber's stays constant, so a wrong closure still pulls
    loop_kernel_width: float = 3.0       # sigmas of the whitened 3-D error norm: a correct
                                         # closure's norm exceeds 3 about 3 % of the time (chi² 3
                                         # dof), and weighs 1/2 there; beyond it a closure counts
                                         # as down-weighted in loop_stats
    relinearize_threshold_m: float = 0.05     # iSAM2 relinearises a variable whose delta
    relinearize_threshold_rad: float = 0.005  # exceeds these (x, y; yaw). Yaw gets its own,
                                         # smaller one: a yaw left linearised 0.01 rad off bends
                                         # a chain by 0.1 m at 10 m (0.05 for all left city10000's
                                         # first 2,000 steps 0.24 m off batch LM; these, 4 cm).
                                         # GTSAM's City10000 example's 0.01 for all, every step,
                                         # gave an 11 ms median step there; these ~2 ms
    relinearize_skip: int = 10           # updates between relinearisations (GTSAM's default):
                                         # nine steps in ten only add and re-eliminate; only the
                                         # top of the Bayes tree is checked (partial check): on
                                         # city10000 its 99th percentile step was 26 ms, 44 ms
                                         # without (one run each, side by side, same error)
    landmark_gate_chi2: float = 30.0     # Mahalanobis² of a sighting against the estimate
                                         # (sighting noise + the estimate's marginals) above which
                                         # it is refused: a correct one exceeds it with
                                         # probability < 2e-6 (chi² 2 or 3 dof)

    def __post_init__(self):
        self.validate(type(self).__name__)

    def validate(self, src: str) -> None:
        positive(src, self, "loop_kernel_width", "relinearize_threshold_m",
                 "relinearize_threshold_rad", "landmark_gate_chi2")
        require(len(self.prior_std) == 3 and all(math.isfinite(s) and s > 0 for s in self.prior_std),
                src, "prior_std", f"must be three positive numbers (m, m, rad), got {self.prior_std!r}")
        require(self.loop_kernel in KERNELS, src, "loop_kernel",
                f"must be one of {list(KERNELS)}, got {self.loop_kernel!r}")
        require(isinstance(self.relinearize_skip, int) and not isinstance(self.relinearize_skip, bool)
                and self.relinearize_skip >= 1, src, "relinearize_skip",
                f"must be an integer >= 1, got {self.relinearize_skip!r}")


def body_covariance(delta, covariance_parent) -> np.ndarray:
    """A 3x3 covariance of (x, y, yaw) errors added in the parent frame, re-expressed in GTSAM's
    Pose2 convention (errors in ``delta``'s own frame): rotate the x-y block by -yaw."""
    c, s = math.cos(delta[2]), math.sin(delta[2])
    J = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return J @ np.asarray(covariance_parent, float) @ J.T


@dataclass
class _Landmark:
    index: int                      # j
    is_pose: bool                   # Pose2 (x, y, yaw) or Point2 (x, y)
    guess: object                   # its value when it enters the graph
    uncommitted: list = field(default_factory=list)   # sighting factors not yet in iSAM2
    entered: bool = False           # its factors have been queued for iSAM2
    sightings: int = 0              # sightings in the graph
    rejected: int = 0               # sightings refused by the gate

    @property
    def key(self) -> int:
        return T(self.index) if self.is_pose else L(self.index)


class PoseGraph:
    """Keyframe poses and tag landmarks, optimised incrementally by iSAM2 (see the module doc)."""

    def __init__(self, settings: GraphSettings = GraphSettings(), first_pose=(0.0, 0.0, 0.0)):
        self.s = settings
        base = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy,
                "huber": gtsam.noiseModel.mEstimator.Huber}[settings.loop_kernel]
        self._kernel = base.Create(settings.loop_kernel_width)
        self._prior_noise = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(settings.prior_std, float))
        self.reset(first_pose)

    # ------------------------------------------------------------------ building the graph
    def reset(self, first_pose=(0.0, 0.0, 0.0)) -> None:
        """Forget everything (time went backwards in a replayed log) and start again with
        keyframe 0 at ``first_pose`` under the prior."""
        params = gtsam.ISAM2Params()
        params.setOptimizationParams(gtsam.ISAM2GaussNewtonParams())
        m, rad = self.s.relinearize_threshold_m, self.s.relinearize_threshold_rad
        thresholds = gtsam.ISAM2ThresholdMap()
        # a bias never: every factor on it is linear in it (relinearising the chain of them each
        # time the newest moved relinearised every yaw-rate factor: p99 19 -> 116 ms on a drive)
        for letter, vector in (("x", [m, m, rad]), ("t", [m, m, rad]), ("l", [m, m]), ("b", [math.inf]),
                               ("k", [SCALE_RELINEARIZE])):
            thresholds.insert((letter, np.array(vector)))
        params.setRelinearizeThreshold(thresholds)
        params.relinearizeSkip = self.s.relinearize_skip
        # QR on the Jacobian, not Cholesky on the normal equations (GTSAM's default): Cholesky
        # squares the condition number, and GTSAM refuses a clique whose R diagonal spans more
        # than 2^18 ("Indeterminate linear system"): on the MIT CSAIL log, 1 mm scan matches
        # against metres of accumulated uncertainty, every update from keyframe ~410 refused.
        # QR took them all, 0.3 ms median (issue 31)
        params.setFactorization("QR")
        params.enablePartialRelinearizationCheck = True
        self._isam = gtsam.ISAM2(params)
        self._graph = gtsam.NonlinearFactorGraph()   # every factor handed to iSAM2
        self._guesses = gtsam.Values()               # the initial value of every variable in it
        self._new_factors = gtsam.NonlinearFactorGraph()   # queued for the next update
        self._new_values = gtsam.Values()
        self._n = 0                   # keyframes added (queued or in iSAM2): the next key
        self._n_done = 0              # keyframes in iSAM2
        self._loops: List[Tuple[int, int, gtsam.BetweenFactorPose2]] = []
        self._loops_done = 0          # loops in iSAM2
        self._landmarks: Dict[str, _Landmark] = {}
        self._next_landmark = 0       # j of the next landmark
        self._biases: List[int] = []  # keyframes with a bias variable B(k), in the order added
        self._biases_done = 0         # of them in iSAM2
        self._scale = 0               # K(0): 0 none, 1 queued, 2 in iSAM2
        self._scale_std: Optional[float] = None   # its marginal's std, until the next update
        self._estimate: Optional[gtsam.Values] = None   # calculateEstimate, until the next update
        first = _pose(first_pose, "first_pose")
        self._new_factors.add(gtsam.PriorFactorPose2(X(0), first, self._prior_noise))
        self._new_values.insert(X(0), first)
        self._n = 1
        self.update()

    def add_keyframe(self, guess, factors: Sequence[Tuple[int, object, object]]) -> int:
        """Queue keyframe ``n`` (the next key) at initial estimate ``guess`` (x, y, yaw), tied
        by ``factors``: (from_key, delta (x, y, yaw) from that key to the new one, 3x3
        covariance), at least one, each from an existing key. Returns the new key."""
        key = self._n
        pose = _pose(guess, f"keyframe {key}: guess")
        if len(factors) == 0:
            raise ValueError(f"keyframe {key}: no factor ties it to the graph")
        built = []
        for n, item in enumerate(factors):
            if len(item) != 3:
                raise ValueError(f"keyframe {key}: factor {n} must be (from_key, delta, covariance)")
            i, delta, cov = item
            what = f"keyframe {key}: factor {n} from key {i}"
            self._check_key(i, what)
            built.append(gtsam.BetweenFactorPose2(X(int(i)), X(key), _pose(delta, f"{what}: delta"),
                                                  _gaussian(cov, 3, f"{what}: covariance")))
        for f in built:
            self._new_factors.add(f)
        self._new_values.insert(X(key), pose)
        self._n += 1
        return key

    def add_loop(self, i: int, j: int, delta, covariance) -> None:
        """Queue a loop closure: pose_i⁻¹ ∘ pose_j measured as ``delta`` with ``covariance``,
        under the robust kernel."""
        what = f"loop {i} -> {j}"
        self._check_key(i, what)
        self._check_key(j, what)
        if int(i) == int(j):
            raise ValueError(f"{what}: a loop closure needs two different keyframes")
        noise = gtsam.noiseModel.Robust.Create(self._kernel, _gaussian(covariance, 3, f"{what}: covariance"))
        factor = gtsam.BetweenFactorPose2(X(int(i)), X(int(j)), _pose(delta, f"{what}: delta"), noise)
        self._new_factors.add(factor)
        self._loops.append((int(i), int(j), factor))

    def add_bias(self, key: int, prior_std: Optional[float] = None, walk_from: Optional[int] = None,
                 walk_std: Optional[float] = None) -> None:
        """Queue the gyro's bias ``B(key)`` (rad/s) at keyframe ``key``: the first one under a prior
        N(0, ``prior_std``²), each later one as a random walk from ``B(walk_from)`` with std
        ``walk_std`` over the time between them (the caller's: sigma sqrt(dt))."""
        what = f"bias at keyframe {key}"
        self._check_key(key, what)
        if self.has_bias(key):
            raise ValueError(f"{what}: already in the graph")
        if (prior_std is None) == (walk_from is None):
            raise ValueError(f"{what}: give either prior_std (the first) or walk_from and walk_std")
        if prior_std is not None:
            noise = gtsam.noiseModel.Isotropic.Sigma(1, _std(prior_std, f"{what}: prior_std") / BIAS_UNIT_RADPS)
            factor, guess = gtsam.PriorFactorDouble(B(int(key)), 0.0, noise), 0.0
        else:
            if not self.has_bias(walk_from):
                raise ValueError(f"{what}: no bias at keyframe {walk_from!r} to walk from")
            noise = gtsam.noiseModel.Isotropic.Sigma(1, _std(walk_std, f"{what}: walk_std") / BIAS_UNIT_RADPS)
            factor = gtsam.BetweenFactorDouble(B(int(walk_from)), B(int(key)), 0.0, noise)
            guess = self.bias(walk_from) / BIAS_UNIT_RADPS
        self._new_factors.add(factor)
        self._new_values.insert(B(int(key)), guess)
        self._biases.append(int(key))

    def add_gyro_scale(self, prior_std: float) -> None:
        """Queue the gyro's scale factor error ``K(0)`` (a fraction: it reads (1 + k) times the
        true turn) under the prior N(0, ``prior_std``²); once per graph."""
        if self._scale:
            raise ValueError("gyro scale: already in the graph")
        noise = gtsam.noiseModel.Isotropic.Sigma(1, _std(prior_std, "gyro scale: prior_std") / SCALE_UNIT)
        self._new_factors.add(gtsam.PriorFactorDouble(K(0), 0.0, noise))
        self._new_values.insert(K(0), 0.0)
        self._scale = 1

    def add_yaw_rate(self, i: int, j: int, reading_rad: float, span_s: float, std_rad: float,
                     bias_key: Optional[int] = None) -> None:
        """Queue a yaw-rate factor: the gyro's rate integrated from keyframe ``i`` to ``j`` over
        ``span_s``, ``reading_rad``, with the std of its white noise ``std_rad``, measures
        (1 + K(0)) (theta_j - theta_i) + B(m) ``span_s``, m = ``bias_key`` (default i: the bias
        at the step's start)."""
        what = f"yaw rate {i} -> {j}"
        self._check_key(i, what)
        self._check_key(j, what)
        m = i if bias_key is None else bias_key
        if not self.has_bias(m):
            raise ValueError(f"{what}: no bias at keyframe {m}")
        if not self._scale:
            raise ValueError(f"{what}: no gyro scale variable (add_gyro_scale)")
        numbers = np.array([reading_rad, span_s], float)
        if not np.all(np.isfinite(numbers)) or span_s < 0.0:
            raise ValueError(f"{what}: reading and span >= 0 must be finite, got {numbers.tolist()}")
        noise = gtsam.noiseModel.Isotropic.Sigma(1, _std(std_rad, f"{what}: std_rad"))
        self._new_factors.add(yaw_rate_factor(X(int(i)), X(int(j)), B(int(m)), K(0), float(reading_rad),
                                              BIAS_UNIT_RADPS * float(span_s), noise))

    def add_landmark(self, name: str, key: int, observation, covariance) -> Optional[str]:
        """A sighting of landmark ``name`` from keyframe ``key`` (already through ``update``):
        (x, y) with a 2x2 covariance in the keyframe's base frame (a position landmark), or
        (x, y, yaw) with a 3x3 covariance in the Pose2 convention (a pose landmark; its yaw is
        then estimated too). A landmark keeps the kind of its first sighting. The first
        sighting is buffered; the landmark enters the graph with the second consistent one.
        Returns None when the sighting was used (buffered or added), else why it was refused:
        its Mahalanobis² against the estimate (``_gate``) is above ``landmark_gate_chi2``. A
        refused second sighting replaces the buffered first, which may have been the wrong one."""
        obs = np.asarray(observation, float)
        what = f"landmark {name!r} from keyframe {key}"
        if obs.shape not in ((2,), (3,)) or not np.all(np.isfinite(obs)):
            raise ValueError(f"{what}: observation must be 2 or 3 finite numbers, got {observation!r}")
        self._check_key(key, what)
        key = int(key)
        if key >= self._n_done:
            raise ValueError(f"{what}: keyframe {key} has not been through update() yet")
        is_pose = obs.shape == (3,)
        lm = self._landmarks.get(name)
        if lm is not None and lm.is_pose != is_pose:
            raise ValueError(f"{what}: seen before as a {'pose' if lm.is_pose else 'position'}, "
                             f"now as a {'pose' if is_pose else 'position'}")
        index = lm.index if lm is not None else self._next_landmark
        lkey = T(index) if is_pose else L(index)
        frame = self._isam.calculateEstimatePose2(X(key))
        if is_pose:
            z = _pose(obs, what)
            factor = gtsam.BetweenFactorPose2(X(key), lkey, z, _gaussian(covariance, 3, f"{what}: covariance"))
            guess = frame.compose(z)
        else:
            factor = _bearing_range(X(key), lkey, obs, covariance, what)
            guess = frame.transformFrom(gtsam.Point2(*obs))
        if lm is None:
            self._landmarks[name] = _Landmark(index, is_pose, guess, [factor])
            self._next_landmark += 1
            return None

        in_isam = self._isam.valueExists(lkey)
        d2 = self._gate(([] if in_isam else lm.uncommitted) + [factor], lm, in_isam)
        if d2 > self.s.landmark_gate_chi2:
            lm.rejected += 1
            if not lm.entered:
                lm.uncommitted, lm.guess = [factor], guess
            return (f"{what}: inconsistent with its estimate (Mahalanobis² {d2:.1f} > "
                    f"{self.s.landmark_gate_chi2:g}), refused ({lm.rejected} so far)")
        if not lm.entered:   # the buffered first sighting goes in with this one
            for f in lm.uncommitted:
                self._new_factors.add(f)
            self._new_values.insert(lkey, lm.guess)
            lm.entered, lm.sightings = True, len(lm.uncommitted)
        self._new_factors.add(factor)
        lm.sightings += 1
        if not in_isam:
            lm.uncommitted.append(factor)
        return None

    # ------------------------------------------------------------------ optimising
    def update(self) -> float:
        """One iSAM2 update with everything queued since the last (nothing queued: one more
        iteration, relinearising what moved); returns the update's wall time (ms). Raises
        ValueError only if iSAM2 itself fails (see the module doc)."""
        factors, values = self._new_factors, self._new_values
        self._new_factors, self._new_values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        before, self._estimate = self._estimate, None
        t0 = time.perf_counter()
        try:
            self._isam.update(factors, values)
        except RuntimeError as exc:
            self._rebuild(before)
            raise ValueError(f"iSAM2 refused the update ({_first_sentence(exc)}): its {factors.size()} new "
                             f"factors dropped, the graph rebuilt from the {self._graph.size()} before") from None
        ms = 1e3 * (time.perf_counter() - t0)
        self._graph.push_back(factors)
        self._guesses.insert(values)
        self._n_done, self._loops_done = self._n, len(self._loops)
        self._biases_done = len(self._biases)
        self._scale = 2 if self._scale else 0
        self._scale_std = None
        for lm in self._landmarks.values():
            if lm.entered:
                lm.uncommitted = []
        return ms

    def _rebuild(self, before: Optional[gtsam.Values]) -> None:
        """After a failed update: forget what it brought (keyframes, loops, landmarks that were
        to enter) and start a fresh iSAM2 from the factors held before, batch-optimised from
        ``before`` (the estimate read after the last good update) or, without it, their initial
        guesses (iSAM2's own estimate is not trusted after a failure)."""
        self._n = self._n_done
        del self._loops[self._loops_done:]
        del self._biases[self._biases_done:]
        self._scale = 2 if self._scale == 2 else 0
        self._landmarks = {name: lm for name, lm in self._landmarks.items()
                           if not lm.entered or self._guesses.exists(lm.key)}
        start = before if before is not None and before.size() == self._guesses.size() else self._guesses
        values = gtsam.LevenbergMarquardtOptimizer(self._graph, start).optimize()
        self._isam = gtsam.ISAM2(self._isam.params())
        self._isam.update(self._graph, values)

    # ------------------------------------------------------------------ results
    def __len__(self) -> int:
        """Keyframes added, queued ones included (the next keyframe's key)."""
        return self._n

    def pose(self, key: int) -> np.ndarray:
        """Keyframe ``key``'s current estimate (x, y, yaw); its guess while still queued."""
        self._check_key(key, f"pose {key}")
        key = int(key)
        p = (self._isam.calculateEstimatePose2(X(key)) if key < self._n_done
             else self._new_values.atPose2(X(key)))
        return np.array([p.x(), p.y(), p.theta()])

    def poses(self) -> np.ndarray:
        """The estimates of the keyframes through update(), (n, 3) in key order."""
        # extractPose2 lists every Pose2 value in key order, and 'x' keys sort after the 't'
        # keys of pose landmarks: the keyframes are the last rows
        return gtsam.utilities.extractPose2(self._current())[-self._n_done:]

    def marginal(self, key: int) -> np.ndarray:
        """Keyframe ``key``'s 3x3 marginal covariance (Pose2 convention)."""
        self._check_key(key, f"marginal {key}")
        key = int(key)
        if key >= self._n_done:
            raise ValueError(f"marginal {key}: keyframe {key} has not been through update() yet")
        return self._isam.marginalCovariance(X(key))

    def last_bias(self) -> Optional[int]:
        """The newest keyframe with a bias variable (queued or in iSAM2); None before the first."""
        return self._biases[-1] if self._biases else None

    def has_bias(self, key) -> bool:
        """Whether keyframe ``key`` has a bias variable (queued or in iSAM2)."""
        return key in self._biases

    def bias(self, key: int) -> float:
        """The gyro bias at keyframe ``key`` (rad/s): iSAM2's estimate, or its guess while queued."""
        if not self.has_bias(key):
            raise ValueError(f"bias {key}: keyframe {key!r} has no bias variable")
        values = self._current() if key in self._biases[:self._biases_done] else self._new_values
        return BIAS_UNIT_RADPS * float(values.atDouble(B(int(key))))

    def bias_std(self, key: int) -> float:
        """The std of the bias at keyframe ``key`` (rad/s), from its marginal."""
        if key not in self._biases[:self._biases_done]:
            raise ValueError(f"bias_std {key}: keyframe {key!r} has no bias through update() yet")
        return BIAS_UNIT_RADPS * math.sqrt(float(self._isam.marginalCovariance(B(int(key)))[0, 0]))

    def gyro_scale(self) -> Optional[Tuple[float, float]]:
        """The gyro's scale factor error (fraction) and its std from the marginal, once it has
        been through ``update``; None before. The std is kept until the next update (``K(0)``
        is touched by every step, so it sits in the Bayes tree's root: its marginal is cheap)."""
        if self._scale != 2:
            return None
        if self._scale_std is None:
            self._scale_std = SCALE_UNIT * math.sqrt(float(self._isam.marginalCovariance(K(0))[0, 0]))
        return SCALE_UNIT * float(self._current().atDouble(K(0))), self._scale_std

    def landmarks(self) -> Dict[str, np.ndarray]:
        """Name -> (x, y) of every landmark in the optimised graph (two sightings or more)."""
        out = {}
        for name, lm in self._landmarks.items():
            if self._isam.valueExists(lm.key):
                p = self._landmark_value(lm)
                out[name] = np.array([p.x(), p.y()]) if lm.is_pose else np.array(p, float)
        return out

    def landmark_poses(self) -> Dict[str, np.ndarray]:
        """Name -> (x, y, yaw) of the pose landmarks in the optimised graph."""
        out = {}
        for name, lm in self._landmarks.items():
            if lm.is_pose and self._isam.valueExists(lm.key):
                p = self._landmark_value(lm)
                out[name] = np.array([p.x(), p.y(), p.theta()])
        return out

    def landmark_marginal(self, name: str) -> np.ndarray:
        """Landmark ``name``'s marginal covariance: 2x2 (x, y) for a position landmark, 3x3
        (Pose2 convention) for a pose landmark."""
        lm = self._landmarks.get(name)
        if lm is None or not self._isam.valueExists(lm.key):
            raise ValueError(f"landmark {name!r} is not in the optimised graph")
        return self._isam.marginalCovariance(lm.key)

    def landmark_stats(self) -> dict:
        """Counts: landmarks in the graph, buffered (one sighting), sightings used, refused."""
        lms = list(self._landmarks.values())
        return {"landmarks": sum(lm.entered for lm in lms),
                "buffered": sum(not lm.entered for lm in lms),
                "sightings": sum(lm.sightings for lm in lms),
                "rejected": sum(lm.rejected for lm in lms)}

    def loops(self) -> List[Tuple[int, int]]:
        """The (i, j) keys of every loop closure added."""
        return [(i, j) for i, j, _ in self._loops]

    def loop_stats(self) -> dict:
        """Loop closures in the optimised graph, at the current estimate: ``added``;
        ``down_weighted``, those whose whitened error norm exceeds ``loop_kernel_width`` (the
        kernel gives them weight below 1/2; Cauchy's falls as (width / error)²), listed in
        ``rejected`` as (i, j, error in sigmas); ``accepted``, the others; ``acceptance_rate``,
        accepted / added (None without loops)."""
        values = self._current()
        rejected = []
        for i, j, f in self._loops[:self._loops_done]:
            e = float(np.linalg.norm(f.noiseModel().noise().whiten(f.unwhitenedError(values))))
            if e > self.s.loop_kernel_width:
                rejected.append((i, j, e))
        added = self._loops_done
        return {"added": added, "down_weighted": len(rejected), "accepted": added - len(rejected),
                "acceptance_rate": (added - len(rejected)) / added if added else None,
                "rejected": rejected}

    def factor_graph(self) -> gtsam.NonlinearFactorGraph:
        """A copy of the factors in iSAM2 (queued ones excluded)."""
        return gtsam.NonlinearFactorGraph(self._graph)

    def initial_values(self) -> gtsam.Values:
        """The initial guess of every variable in iSAM2 (e.g. to start a batch optimiser)."""
        return gtsam.Values(self._guesses)

    def estimate(self) -> gtsam.Values:
        """iSAM2's current estimate of every variable (keys ``X(k)``, ``L(j)``, ``T(j)``)."""
        return gtsam.Values(self._current())

    def save_g2o(self, path: str) -> None:
        """Write the Pose2 part of the graph with the current estimate through
        ``gtsam.writeG2o``: keyframe k as vertex k, pose landmark j as vertex n + j (n
        keyframes), every between-factor among them, loop closures with their Gaussian (g2o has
        no robust kernel). Position landmarks and the prior are left out: writeG2o writes
        neither (``gtsam.readG2o`` reads the file back)."""
        values, n = self._current(), self._n_done
        out = gtsam.Values()
        for k in range(n):
            out.insert(k, values.atPose2(X(k)))
        for lm in self._landmarks.values():
            if lm.is_pose and values.exists(lm.key):
                out.insert(n + lm.index, values.atPose2(lm.key))
        def vertex(key: int) -> int:
            symbol = gtsam.Symbol(key)
            return symbol.index() + (n if symbol.chr() == ord("t") else 0)

        graph = gtsam.NonlinearFactorGraph()
        for idx in range(self._graph.size()):
            f = self._graph.at(idx)
            if isinstance(f, gtsam.BetweenFactorPose2):
                model = f.noiseModel()
                if isinstance(model, gtsam.noiseModel.Robust):
                    model = model.noise()
                a, b = f.keys()
                graph.add(gtsam.BetweenFactorPose2(vertex(a), vertex(b), f.measured(), model))
        gtsam.writeG2o(graph, out, str(path))

    # ------------------------------------------------------------------ internals
    def _current(self) -> gtsam.Values:
        if self._estimate is None:
            self._estimate = self._isam.calculateEstimate()
        return self._estimate

    def _landmark_value(self, lm: _Landmark):
        return (self._isam.calculateEstimatePose2(lm.key) if lm.is_pose
                else self._isam.calculateEstimatePoint2(lm.key))

    def _check_key(self, key, what: str) -> None:
        if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= key < self._n:
            raise ValueError(f"{what}: no keyframe {key!r} (keys are 0..{self._n - 1})")

    def _gate(self, factors: list, lm: _Landmark, in_isam: bool) -> float:
        """Mahalanobis² of ``factors`` (sightings of ``lm``) against the estimate.

        Linearised and whitened at the current estimate, the factors read
        ``b = A_r d_r + A_l d_l + n``, n ~ N(0, I): ``d_r`` the variables in iSAM2, distributed
        as their joint marginal ``S``; ``d_l`` the landmark while it is not in iSAM2 yet, free
        (then its buffered sighting is among the factors). With ``C = I + A_r S A_rᵀ`` the
        statistic is the generalised least-squares residual ``min over d_l of
        (b - A_l d_l)ᵀ C⁻¹ (b - A_l d_l)``: chi² with (rows - free dimensions) degrees of freedom."""
        values = gtsam.Values()
        lkey = lm.key
        values.insert(lkey, self._landmark_value(lm) if in_isam else lm.guess)
        poses = sorted({k for f in factors for k in f.keys() if k != lkey})
        for k in poses:
            values.insert(k, self._isam.calculateEstimatePose2(k))
        rand = poses + [lkey] if in_isam else poses
        dim_l = 3 if lm.is_pose else 2
        col = {k: 3 * i for i, k in enumerate(poses + [lkey])}   # landmark last: 2 or 3 wide
        width = 3 * len(poses) + dim_l
        A_rows, b_rows = [], []
        for f in factors:
            Ab, b = f.linearize(values).jacobian()
            A, c = np.zeros((len(b), width)), 0
            for k in f.keys():
                d = dim_l if k == lkey else 3
                A[:, col[k]:col[k] + d] += Ab[:, c:c + d]
                c += d
            A_rows.append(A)
            b_rows.append(b)
        A, b = np.vstack(A_rows), np.concatenate(b_rows)
        n_rand = width if in_isam else 3 * len(poses)
        A_r, A_l = A[:, :n_rand], A[:, n_rand:]
        joint = self._isam.jointMarginalCovariance(gtsam.KeyVector(rand))
        S = np.block([[joint.at(a, c) for c in rand] for a in rand])
        Ci = np.linalg.inv(np.eye(len(b)) + A_r @ S @ A_r.T)
        d2 = float(b @ Ci @ b)
        if A_l.shape[1]:
            g = A_l.T @ Ci @ b
            d2 -= float(g @ np.linalg.solve(A_l.T @ Ci @ A_l, g))
        return d2


def _first_sentence(exc: Exception) -> str:
    """GTSAM's exception text (several paragraphs) cut to its first sentence, on one line:
    "Indeterminate linear system detected while working near variable ... (Symbol: x181)."."""
    text = " ".join(str(exc).split())
    return text.split(". ")[0].rstrip(".") if text else type(exc).__name__


def _pose(p, what: str) -> gtsam.Pose2:
    a = np.asarray(p, float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: must be 3 finite numbers (x, y, yaw), got {p!r}")
    return gtsam.Pose2(*a)


def _checked_covariance(cov, n: int, what: str) -> np.ndarray:
    c = np.asarray(cov, float)
    if c.shape != (n, n) or not np.all(np.isfinite(c)):
        raise ValueError(f"{what}: must be a finite {n}x{n} matrix, got {cov!r}")
    if not np.allclose(c, c.T, rtol=1e-6, atol=1e-12):
        raise ValueError(f"{what}: not symmetric: {c.tolist()}")
    eig = np.linalg.eigvalsh(c)
    if eig.min() <= 0.0:
        raise ValueError(f"{what}: not positive definite (eigenvalues {eig.tolist()})")
    return 0.5 * (c + c.T)


def _gaussian(cov, n: int, what: str) -> gtsam.noiseModel.Gaussian:
    return gtsam.noiseModel.Gaussian.Covariance(_checked_covariance(cov, n, what))


def _bearing_range(pose_key: int, point_key: int, xy: np.ndarray, cov, what: str):
    """A position sighting (x, y and its 2x2 covariance in the keyframe's frame) as bearing and
    range, the covariance carried through the Jacobian of (atan2(y, x), |xy|)."""
    c = _checked_covariance(cov, 2, f"{what}: covariance")
    r = float(np.hypot(*xy))
    if r < MIN_LANDMARK_RANGE_M:
        raise ValueError(f"{what}: range {r:.3f} m is below {MIN_LANDMARK_RANGE_M} m (no bearing)")
    J = np.array([[-xy[1] / r ** 2, xy[0] / r ** 2], [xy[0] / r, xy[1] / r]])
    noise = gtsam.noiseModel.Gaussian.Covariance(J @ c @ J.T)
    return gtsam.BearingRangeFactor2D(pose_key, point_key, gtsam.Rot2(math.atan2(xy[1], xy[0])), r, noise)


def yaw_rate_factor(key_i: int, key_j: int, key_bias: int, key_scale: int, reading_rad: float,
                    bias_gain: float, noise) -> gtsam.CustomFactor:
    """The gyro's turn between two Pose2 keyframes, bias and scale error included:
    error = wrap((1 + k SCALE_UNIT) dtheta + b bias_gain - reading_rad), dtheta = wrap(theta_j -
    theta_i), b in the bias variable's unit and ``bias_gain`` the turn one unit of it makes over
    the step, k the scale variable's. A Pose2's tangent is (x, y, theta) in its own frame, so
    the headings' Jacobians are (0, 0, -+(1 + k)), the bias's the gain, the scale's dtheta."""
    def error(this: gtsam.CustomFactor, values: gtsam.Values, H: Optional[List[np.ndarray]]) -> np.ndarray:
        keys = this.keys()
        turn = wrap_angle(values.atPose2(keys[1]).theta() - values.atPose2(keys[0]).theta())
        b = values.atDouble(keys[2])
        gain = 1.0 + SCALE_UNIT * values.atDouble(keys[3])
        if H is not None:
            H[0] = np.array([[0.0, 0.0, -gain]])
            H[1] = np.array([[0.0, 0.0, gain]])
            H[2] = np.array([[bias_gain]])
            H[3] = np.array([[SCALE_UNIT * turn]])
        return np.array([wrap_angle(gain * turn + b * bias_gain - reading_rad)])

    return gtsam.CustomFactor(noise, gtsam.KeyVector([key_i, key_j, key_bias, key_scale]), error)


def _std(value, what: str) -> float:
    if value is None or not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{what}: must be a positive finite std, got {value!r}")
    return float(value)
