"""Trajectory accuracy: TUM files, the absolute trajectory error and the relations metric.

A trajectory is an (n, 4) array of rows ``(t_s, x_m, y_m, yaw_rad)`` sorted by time, planar.

- TUM format (Sturm et al. 2012, the RGB-D benchmark): one pose per line,
  ``t x y z qx qy qz qw``; ``#`` starts a comment. Read here as planar: z, roll and pitch are
  dropped, yaw taken from the quaternion.
- ATE: the RMSE of the position differences between estimated and ground-truth poses paired by
  nearest time stamp (within ``max_dt_s``), after an optional SE(2) least-squares alignment of
  the estimate onto the ground truth (Umeyama 1991 / Horn 1987 without scale), for datasets
  whose frames differ. The simulator's ground truth is in the odometry's start frame: no
  alignment by default.
- Relations (Kümmerle et al. 2009, "On measuring the accuracy of SLAM algorithms"): a
  ``.relations`` file lists ``t1 t2 x y z roll pitch yaw``, the true motion from the pose at t1
  to the pose at t2 in the frame of the first. For each, the estimate's motion between its
  poses at t1 and t2 (interpolated) is compared with it as Cartographer's
  ``compute_relations_metrics`` does (the tool behind the tables of Hess et al. 2016):
  ``error = (pose1⁻¹ pose2) expected⁻¹``, translational error = |translation of error| (m),
  rotational error = |angle of error| (deg); reported as mean and sample standard deviation,
  and the same for the squared errors. It does not depend on the estimate's global frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Tuple, Union

import numpy as np

from ..geometry import between, compose, inverse, transform_points, wrap_angle, yaw_from_quaternion  # noqa: F401 (re-exported)


def _numbers(path: Union[str, Path], columns: int, what: str) -> np.ndarray:
    """Rows of ``columns`` numbers from a text file; ValueError naming the first bad line."""
    rows = []
    with open(path) as f:
        for lineno, line in enumerate(f, 1):
            text = line.split("#", 1)[0].replace(",", " ").split()
            if not text:
                continue
            if len(text) != columns:
                raise ValueError(f"{path}:{lineno}: a {what} line has {columns} numbers, this one {len(text)}")
            try:
                row = [float(v) for v in text]
            except ValueError:
                raise ValueError(f"{path}:{lineno}: not a number in {line.strip()[:60]!r}") from None
            if not all(math.isfinite(v) for v in row):
                raise ValueError(f"{path}:{lineno}: a value is not finite")
            rows.append(row)
    if not rows:
        raise ValueError(f"{path}: no {what} lines")
    return np.array(rows)


def read_tum(path: Union[str, Path]) -> np.ndarray:
    """(n, 4) ``t, x, y, yaw`` sorted by time. OSError if unreadable, ValueError if malformed."""
    a = _numbers(path, 8, "TUM")
    traj = np.column_stack([a[:, 0], a[:, 1], a[:, 2], yaw_from_quaternion(*a[:, 4:8].T)])
    return traj[np.argsort(traj[:, 0], kind="stable")]


def write_tum(path: Union[str, Path], traj: np.ndarray) -> None:
    """Write ``(t, x, y, yaw)`` rows as TUM lines (z = 0, rotation about z only)."""
    traj = np.asarray(traj, float).reshape(-1, 4)
    with open(path, "w") as f:
        f.write("# t x y z qx qy qz qw\n")
        for t, x, y, yaw in traj:
            f.write(f"{t:.6f} {x:.6f} {y:.6f} 0 0 0 {math.sin(0.5 * yaw):.9f} {math.cos(0.5 * yaw):.9f}\n")


def associate(t_est: np.ndarray, t_gt: np.ndarray, max_dt_s: float) -> Tuple[np.ndarray, np.ndarray]:
    """Indices (i_est, i_gt) pairing each estimate with the ground-truth pose nearest in time,
    kept when within ``max_dt_s``. ``t_gt`` sorted."""
    t_est, t_gt = np.asarray(t_est, float), np.asarray(t_gt, float)
    j = np.clip(np.searchsorted(t_gt, t_est), 1, len(t_gt) - 1) if len(t_gt) > 1 else np.zeros(len(t_est), int)
    if len(t_gt) > 1:
        j = np.where(np.abs(t_gt[j - 1] - t_est) <= np.abs(t_gt[j] - t_est), j - 1, j)
    keep = np.abs(t_gt[j] - t_est) <= max_dt_s
    return np.nonzero(keep)[0], j[keep]


def align_se2(src_xy: np.ndarray, dst_xy: np.ndarray) -> np.ndarray:
    """The rigid motion (x, y, yaw) T minimising sum |T ⊕ src_i - dst_i|² (Umeyama without scale)."""
    src, dst = np.asarray(src_xy, float), np.asarray(dst_xy, float)
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    # cross-covariance of the centred points: H = sum (src_i - mu_s)(dst_i - mu_d)^T
    h = (src - mu_s).T @ (dst - mu_d)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0     # a reflection is not a rotation
    r = vt.T @ np.diag([1.0, d]) @ u.T
    t = mu_d - r @ mu_s
    return np.array([t[0], t[1], math.atan2(r[1, 0], r[0, 0])])


@dataclass(frozen=True)
class AteResult:
    rmse_m: float
    mean_m: float
    median_m: float
    max_m: float
    matched: int                  # estimated poses paired with a ground-truth pose
    total: int                    # estimated poses
    alignment: Tuple[float, float, float] = (0.0, 0.0, 0.0)   # (x m, y m, yaw rad) applied to the estimate

    def as_dict(self) -> dict:
        return {"ate_rmse_m": self.rmse_m, "ate_mean_m": self.mean_m, "ate_median_m": self.median_m,
                "ate_max_m": self.max_m, "ate_matched": self.matched, "ate_total": self.total,
                "ate_alignment": list(self.alignment)}


def ate(est: np.ndarray, gt: np.ndarray, max_dt_s: float = 0.02, align: bool = False) -> AteResult:
    """Absolute trajectory error of ``est`` against ``gt`` (both (n, 4), sorted by time);
    ValueError when no pose pairs up."""
    est, gt = np.asarray(est, float), np.asarray(gt, float)
    i, j = associate(est[:, 0], gt[:, 0], max_dt_s)
    if len(i) == 0:
        raise ValueError(f"no estimated pose within {max_dt_s} s of a ground-truth pose "
                         f"(estimate {est[0, 0]:.3f}..{est[-1, 0]:.3f} s, "
                         f"ground truth {gt[0, 0]:.3f}..{gt[-1, 0]:.3f} s)")
    xy = est[i, 1:3]
    transform = np.zeros(3)
    if align and len(i) >= 2:
        transform = align_se2(xy, gt[j, 1:3])
        xy = transform_points(transform, xy)
    e = np.linalg.norm(xy - gt[j, 1:3], axis=1)
    return AteResult(float(np.sqrt(np.mean(e ** 2))), float(e.mean()), float(np.median(e)), float(e.max()),
                     len(i), len(est), tuple(float(v) for v in transform))


def interpolate(traj: np.ndarray, t: np.ndarray, max_dt_s: float = 0.0) -> np.ndarray:
    """(m, 3) poses of ``traj`` at times ``t``: linear in x, y and (unwrapped) yaw between the
    poses around each time; NaN rows for times more than ``max_dt_s`` outside the trajectory."""
    traj, t = np.asarray(traj, float), np.asarray(t, float)
    yaw = np.unwrap(traj[:, 3])
    out = np.column_stack([np.interp(t, traj[:, 0], traj[:, 1]), np.interp(t, traj[:, 0], traj[:, 2]),
                           wrap_angle(np.interp(t, traj[:, 0], yaw))])
    outside = (t < traj[0, 0] - max_dt_s) | (t > traj[-1, 0] + max_dt_s)
    out[outside] = np.nan
    return out


def read_relations(path: Union[str, Path]) -> np.ndarray:
    """(n, 5) ``t1, t2, x, y, yaw`` of a Kümmerle ``.relations`` file (z, roll, pitch dropped)."""
    a = _numbers(path, 8, "relations")
    return a[:, [0, 1, 2, 3, 7]]


def write_relations(path: Union[str, Path], relations: np.ndarray) -> None:
    with open(path, "w") as f:
        for t1, t2, x, y, yaw in np.asarray(relations, float).reshape(-1, 5):
            f.write(f"{t1:.6f} {t2:.6f} {x:.6f} {y:.6f} 0.000000 0.000000 0.000000 {yaw:.6f}\n")


def make_relations(gt: np.ndarray, every_s: Optional[float] = None, every_m: Optional[float] = None) -> np.ndarray:
    """Relations (n, 5) from a ground-truth trajectory: a chain of pose pairs, each from the
    last pair's end to the first pose ``every_s`` later (or ``every_m`` further along the path)."""
    if (every_s is None) == (every_m is None):
        raise ValueError("make_relations: give exactly one of every_s, every_m")
    gt = np.asarray(gt, float)
    along = gt[:, 0] if every_s is not None else np.concatenate(
        [[0.0], np.cumsum(np.linalg.norm(np.diff(gt[:, 1:3], axis=0), axis=1))])
    step = every_s if every_s is not None else every_m
    rows, i = [], 0
    while True:
        j = int(np.searchsorted(along, along[i] + step - 1e-9))
        if j >= len(gt):
            break
        rows.append([gt[i, 0], gt[j, 0], *between(gt[i, 1:4], gt[j, 1:4])])
        i = j
    return np.array(rows).reshape(-1, 5)


@dataclass(frozen=True)
class RelationsResult:
    used: int                  # relations whose both times fall on the estimate
    missing: int               # relations outside the estimate's time span
    trans_mean_m: float
    trans_std_m: float
    rot_mean_deg: float
    rot_std_deg: float
    trans_sq_mean_m2: float
    trans_sq_std_m2: float
    rot_sq_mean_deg2: float
    rot_sq_std_deg2: float

    def as_dict(self) -> dict:
        return {f"relations_{k}": (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in self.__dict__.items()}


def relation_errors(est: np.ndarray, relations: np.ndarray, max_dt_s: float = 0.02) -> Tuple[np.ndarray, np.ndarray]:
    """(translational m, rotational rad) error of each relation that falls on the estimate."""
    rel = np.asarray(relations, float).reshape(-1, 5)
    p1, p2 = interpolate(est, rel[:, 0], max_dt_s), interpolate(est, rel[:, 1], max_dt_s)
    ok = np.isfinite(p1[:, 0]) & np.isfinite(p2[:, 0])
    error = compose(between(p1[ok], p2[ok]), inverse(rel[ok, 2:5]))   # (pose1⁻¹ pose2) expected⁻¹
    return np.linalg.norm(error[:, :2], axis=1), np.abs(error[:, 2])


def relations_error(est: np.ndarray, relations: np.ndarray, max_dt_s: float = 0.02) -> RelationsResult:
    """The relations metric of ``est`` over ``relations``; ValueError when none falls on it."""
    rel = np.asarray(relations, float).reshape(-1, 5)
    trans, rot = relation_errors(est, rel, max_dt_s)
    if len(trans) == 0:
        raise ValueError(f"none of the {len(rel)} relations falls within the estimate's time span "
                         f"({est[0, 0]:.3f}..{est[-1, 0]:.3f} s)")
    rot_deg = np.degrees(rot)

    def mean_std(v: np.ndarray) -> Tuple[float, float]:
        return float(v.mean()), (float(v.std(ddof=1)) if len(v) > 1 else math.nan)

    return RelationsResult(len(trans), len(rel) - len(trans), *mean_std(trans), *mean_std(rot_deg),
                           *mean_std(trans ** 2), *mean_std(rot_deg ** 2))
