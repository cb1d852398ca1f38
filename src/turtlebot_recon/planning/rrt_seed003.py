"""Seed 003's RRT, reproduced as the baseline planner: facade over ``_native.rrt_seed003``
(include/turtlebot_recon/rrt_seed003.hpp has the algorithm step by step).

Seed 003 (section 3.3) samples the goal 30 % of the time and a random cell otherwise, steps 4
cells from the nearest tree node toward the sample, keeps the new node when a hit-box of
BOT_WIDTH_CLEARANCE x BOT_LENGTH_CLEARANCE cells is free at it and along the connection, joins
the goal from within one step, gives up after SMAX = 25,000 steps or NMAX = 10,000 nodes, and
shortens the path by a two-pointer shortcut. Its settings below are the seed's values.

The hit-box rule. The seed's robot measured 7 x 7 cells and its hit-box 10 x 10: the footprint
plus 3 cells of clearance. The box is axis-aligned on the grid and centred on the robot's
position; it does not turn with the robot. So here a robot's hit-box is a square of
``ceil(s / resolution) + clearance_cells`` cells a side, s being the footprint's larger side (a
box's length or width, a disc's diameter): at 0.05 m the waffle_pi's 0.281 x 0.306 m box gives
7 + 3 = 10 cells (0.5 m, the seed's own numbers), the burger's 0.21 m disc 5 + 3 = 8 (0.4 m).

Points are (x, y) in metres in the grid's frame (``origin`` is the (x, y) of cell (0, 0)'s
corner); the planner works in cells (x = column, y = row) and the path's ends are the given
points exactly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .. import _native
from ..config import positive, require
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import RobotSpec
from .costmap import PlanningError


@dataclass(frozen=True)
class RrtSeed003Settings:
    goal_select_fraction: float = 0.3  # RRT_GOAL_SELECT_FRACTION: share of samples that are the goal (1)
    step_cells: float = 4.0            # RRT_STEP_SCALE: extension step (cells)
    clearance_cells: int = 3           # hit-box side beyond the footprint's (cells): BOT_WIDTH_CLEARANCE
                                       # = BOT_LENGTH_CLEARANCE = 10 for the seed's 7-cell robot
    max_steps: int = 25000             # SMAX: sampling steps before giving up
    max_nodes: int = 10000             # NMAX: tree nodes before giving up
    shortcut: bool = True              # the seed's two-pointer post-processing
    unknown_is_obstacle: bool = True   # unknown cells (-1) block the hit-box, as occupied ones

    def validate(self, src: str) -> None:
        require(0.0 <= self.goal_select_fraction <= 1.0, src, "goal_select_fraction", "must be in [0, 1]")
        positive(src, self, "step_cells", "max_steps")
        require(self.clearance_cells >= 0, src, "clearance_cells", "must be >= 0")
        require(self.max_nodes >= 2, src, "max_nodes", "must be >= 2 (the start and the goal)")


@dataclass(frozen=True)
class RrtSeed003Path:
    points: np.ndarray     # float (n, 2): x, y (m), start ... goal, after the shortcut
    length_m: float        # of the polyline
    nodes: int             # tree nodes grown (the start and the goal included)
    steps: int             # sampling steps taken
    goal_samples: int      # of those, steps that sampled the goal
    hitbox_cells: int      # the hit-box's side (cells)


def hitbox_cells(robot: RobotSpec, resolution: float, settings: RrtSeed003Settings) -> int:
    """The square hit-box's side (cells): the footprint's larger side in whole cells plus
    ``clearance_cells`` (the module's docstring derives the rule from the seed)."""
    side_m = 2.0 * robot.radius_m if robot.is_round else max(robot.footprint_length_m,
                                                             robot.footprint_width_m)
    return int(math.ceil(side_m / resolution - 1e-9)) + settings.clearance_cells


def plan_rrt_seed003(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                     robot: RobotSpec, start_xy: Sequence[float], goal_xy: Sequence[float],
                     settings: RrtSeed003Settings = RrtSeed003Settings(), seed: int = 0) -> RrtSeed003Path:
    """Seed 003's RRT from ``start_xy`` to ``goal_xy`` (m) on an int8 occupancy grid (-1 unknown,
    0..100) for ``robot``'s hit-box; ``seed`` seeds its std::mt19937 (same seed, same path).

    Raises PlanningError in one line when the start or goal is off the map, in an obstacle or
    its hit-box is not free, and when no path is found within SMAX steps / NMAX nodes."""
    settings.validate("RrtSeed003Settings")
    require(int(seed) == seed and 0 <= seed < 2 ** 32, "plan_rrt_seed003", "seed", "must be an integer in [0, 2^32)")
    side = hitbox_cells(robot, resolution, settings)
    to_cells = lambda p: ((float(p[0]) - origin[0]) / resolution, (float(p[1]) - origin[1]) / resolution)  # noqa: E731
    ends = f"start ({start_xy[0]:.3f}, {start_xy[1]:.3f}) m, goal ({goal_xy[0]:.3f}, {goal_xy[1]:.3f}) m"
    try:
        out = _native.rrt_seed003(
            np.ascontiguousarray(occupancy, dtype=np.int8), to_cells(start_xy), to_cells(goal_xy),
            seed=int(seed), goal_fraction=settings.goal_select_fraction, step_cells=settings.step_cells,
            hitbox_width_cells=side, hitbox_length_cells=side, max_steps=settings.max_steps,
            max_nodes=settings.max_nodes, shortcut=settings.shortcut,
            occupied_threshold=OCCUPIED_THRESH, unknown_is_obstacle=settings.unknown_is_obstacle)
    except ValueError as exc:
        raise PlanningError(f"plan_rrt_seed003 ({ends}): {exc}") from exc
    if not out["found"]:
        raise PlanningError(f"plan_rrt_seed003: no path ({ends}) in {out['steps']} steps, "
                            f"{out['nodes']} nodes (limits {settings.max_steps} steps, "
                            f"{settings.max_nodes} nodes; hit-box {side} x {side} cells)")
    points = np.asarray(origin[:2], dtype=float) + out["path"] * resolution
    return RrtSeed003Path(points=points, length_m=float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()),
                          nodes=int(out["nodes"]), steps=int(out["steps"]),
                          goal_samples=int(out["goal_samples"]), hitbox_cells=side)
