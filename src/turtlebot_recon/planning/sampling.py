"""OMPL's sampling planners for the oriented footprint: facade over ``_native.plan_sampling``.

RRT-Connect, RRT*, Informed RRT*, PRM* and BIT* plan in SE(2) with the lattice's motion model
and costs (include/turtlebot_recon/sampling_planner.hpp): turn in place, drive straight
(backward where the lattice would, dearer), turn in place; the footprint ``margin_m`` off every obstacle cell's square, the centre on known
free cells; metres driven plus the turning cost. OMPL's simplifier shortens the path, and the
path returned is the one a follower drives: straight segments, forward where that is clear,
a turn in place at each vertex from one segment's heading to the next. Any-angle where the lattice keeps to
16 headings, but random: OMPL draws from its own process-wide generator, so two runs differ.

Poses are (x, y, yaw) in metres and radians in the grid's frame (``origin``: the (x, y) of
cell (0, 0)'s corner), as in ``planning.lattice``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .. import _native, geometry
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import RobotSpec, footprint_args
from .costmap import PlanningError
from .lattice import LatticePath, LatticeSettings

OMPL_PLANNERS = tuple(_native.sampling_planners())   # rrtconnect, rrtstar, informed_rrtstar, prmstar, bitstar
GLOBAL_PLANNERS = ("lattice",) + tuple(f"ompl_{name}" for name in OMPL_PLANNERS)  # the navigator's


@dataclass(frozen=True)
class SampledPath:
    poses: np.ndarray      # float (n, 3): start ... goal; each inner yaw the heading held on
                           # the segment into it (facing back where that one is backward)
    reversed: np.ndarray   # bool (n,): the segment into the pose is driven backward
    length_m: float        # driven
    reversed_m: float      # of length_m, driven backward
    turned_rad: float      # turned in place (the start's and the goal's turns included)
    cost_m: float          # the lattice's cost: metres driven (backward ones dearer) + turning
    solve_s: float         # wall time of OMPL's solve
    simplify_s: float      # wall time of the simplification


def plan_sampling(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                  robot: RobotSpec, start: Sequence[float], goal: Sequence[float],
                  planner: str = "rrtconnect", budget_s: float = 0.2,
                  settings: LatticeSettings = LatticeSettings(), simplify: bool = True) -> SampledPath:
    """An OMPL plan from ``start`` (x, y, yaw) to ``goal`` ((x, y): at any of the lattice's
    headings where the footprint fits; (x, y, yaw): at that yaw) within ``budget_s`` of solve
    time (the simplifier may take as long again), with ``settings``' margin_m and turning cost.
    Raises PlanningError with one line when there is none (start or goal blocked, no path in
    the budget); ValueError for an unknown planner or a bad argument."""
    settings = settings.with_robot(robot)
    settings.validate("LatticeSettings")
    ox, oy = float(origin[0]), float(origin[1])
    if len(goal) >= 3 and goal[2] is not None:
        yaws = [float(goal[2])]
    else:
        yaws = [yaw for _, _, yaw in _native.lattice_headings(settings.headings)]
    out = _native.plan_sampling(
        occupancy, resolution, (float(start[0]) - ox, float(start[1]) - oy, float(start[2])),
        (float(goal[0]) - ox, float(goal[1]) - oy), yaws, planner, budget_s,
        **footprint_args(robot), margin_m=settings.margin_m, turn_margin_m=settings.turn_margin_m,
        turn_cost_m_per_rad=settings.turn_cost_m_per_rad,
        reverse_cost_factor=settings.reverse_cost_factor, occupied_threshold=OCCUPIED_THRESH,
        simplify=simplify)
    return _sampled_path(out, (ox, oy), f"plan_sampling ({planner})")


def shortcut_turn_drive(occupancy: np.ndarray, resolution: float, origin: Sequence[float], robot: RobotSpec,
                        points: np.ndarray, start_yaw: float,
                        settings: LatticeSettings = LatticeSettings()) -> SampledPath:
    """A 2-D path's ``points`` ((n, 2) m in the grid's frame, e.g. A*'s cell centres; the first
    the start, the robot facing ``start_yaw``) shortened for ``robot``'s footprint as the follower
    drives it: from each kept pose, the farthest later point reached by a turn in place and a
    straight drive (backward where ``settings`` lets it back), the body ``settings``' margins off
    every obstacle (``_native.shortcut_turn_drive``). PlanningError with one line where some
    kept pose reaches no later point; ValueError for a bad argument."""
    settings = settings.with_robot(robot)
    settings.validate("LatticeSettings")
    ox, oy = float(origin[0]), float(origin[1])
    pts = np.asarray(points, dtype=float).reshape(-1, 2) - (ox, oy)
    out = _native.shortcut_turn_drive(
        occupancy, resolution, pts, float(start_yaw), **footprint_args(robot), margin_m=settings.margin_m,
        turn_margin_m=settings.turn_margin_m, turn_cost_m_per_rad=settings.turn_cost_m_per_rad,
        reverse_cost_factor=settings.reverse_cost_factor, occupied_threshold=OCCUPIED_THRESH)
    return _sampled_path(out, (ox, oy), "shortcut_turn_drive")


def _sampled_path(out: dict, origin: tuple, caller: str) -> SampledPath:
    """The C++ result ``out`` (poses from the grid's corner) as a SampledPath in the grid's frame;
    PlanningError naming ``caller`` and the reason when it is not solved."""
    if not out["solved"]:
        raise PlanningError(f"{caller}: {out['reason']}")
    poses = out["poses"]
    poses[:, 0] += origin[0]
    poses[:, 1] += origin[1]
    return SampledPath(poses=poses, reversed=out["reversed"], length_m=out["length_m"],
                       reversed_m=out["reversed_m"], turned_rad=out["turned_rad"],
                       cost_m=out["cost_m"], solve_s=out["solve_s"], simplify_s=out["simplify_s"])


def as_lattice_path(path: SampledPath, resolution: float, origin: Sequence[float]) -> LatticePath:
    """``path`` in the lattice's form, for the navigator (which follows the runs between turns
    and backs where a plan does): a pose at each turn in place (turned) and every cell or less
    along each straight segment (reversed where it is driven backward); cells are those poses'
    cells, headings -1 (off the lattice's)."""
    P, back = path.poses, path.reversed
    poses, turned, reversed_ = [P[0]], [False], [False]
    for i in range(1, len(P)):
        (x0, y0), (x1, y1) = P[i - 1, :2], P[i, :2]
        d = math.hypot(x1 - x0, y1 - y0)
        if d > 1e-9:
            held = math.atan2(y1 - y0, x1 - x0) + (math.pi if back[i] else 0.0)
            if abs(geometry.wrap_angle(held - poses[-1][2])) > 1e-9:
                poses.append(np.array([x0, y0, held])), turned.append(True), reversed_.append(False)
            n = max(1, math.ceil(d / resolution))
            for t in np.arange(1, n + 1) / n:
                poses.append(np.array([x0 + t * (x1 - x0), y0 + t * (y1 - y0), held]))
                turned.append(False), reversed_.append(bool(back[i]))
        if abs(geometry.wrap_angle(P[i, 2] - poses[-1][2])) > 1e-9:
            poses.append(np.array([x1, y1, P[i, 2]])), turned.append(True), reversed_.append(False)
    poses = np.array(poses)
    rows, cols = geometry.points_to_cells(poses[:, :2], resolution, origin)
    return LatticePath(poses=poses, cells=np.column_stack([rows, cols]).astype(np.int32),
                       headings=np.full(len(poses), -1, np.int32), turned=np.array(turned),
                       reversed=np.array(reversed_), cost=path.cost_m, length_m=path.length_m,
                       turned_rad=path.turned_rad, reversed_m=path.reversed_m)
