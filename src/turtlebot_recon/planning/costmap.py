"""Costmap and global planner facade over ``turtlebot_recon._native``.

Grids are row-major ``(rows, cols)`` with row 0 at the smallest y (nav_msgs/OccupancyGrid
order); cells are ``(row, col)``. Costs follow the move_base / Nav2 convention: 0 free,
1..252 graded, 253 inscribed, 254 lethal, 255 unknown.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .. import _native
from ..config import positive, require
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import RobotSpec

FREE_SPACE = 0
INSCRIBED = 253
LETHAL = 254
NO_INFORMATION = 255

Cell = Tuple[int, int]


class PlanningError(RuntimeError):
    """No path: the start or goal is off the grid or impassable, or the goal is unreachable."""


@dataclass(frozen=True)
class CostmapSettings:
    inscribed_radius_m: float = 0.105     # robot centre closer than this to an obstacle cell's
                                          # edge: collision (see make_costmap)
    inflation_radius_m: float = 0.455     # graded cost out to this distance from obstacle edges
    cost_scaling_factor: float = 5.0      # 1/m, decay of the graded cost past the inscribed radius
    unknown_is_obstacle: bool = False     # unknown cells: lethal instead of NO_INFORMATION (255)

    def validate(self, src: str) -> None:
        positive(src, self, "inscribed_radius_m", "inflation_radius_m")
        require(self.inflation_radius_m >= self.inscribed_radius_m, src, "inflation_radius_m",
                f"must be >= inscribed_radius_m ({self.inscribed_radius_m})")
        require(self.cost_scaling_factor >= 0, src, "cost_scaling_factor", "must be >= 0")

    @classmethod
    def for_robot(cls, robot: RobotSpec) -> "CostmapSettings":
        """Settings for ``robot``: inscribed radius from its footprint, Nav2-style inflation.

        The inscribed radius is the footprint's circumscribed radius about base_footprint
        (``radius_m``): a differential-drive robot turns in place about that point, and a box
        body (the waffle_pi's reaches 0.257 m behind and beside the axle, its inscribed circle
        only 0.14 m) sweeps that whole disc. Checking the centre against it makes every heading
        safe, and it is the radius of DESIGN §6's reachable space F.

        Inflation reaches 0.35 m beyond the body and decays at 5 /m: at the edge of the band
        the cost is still floor(252 exp(-5 * 0.35)) = 43, so the planner feels walls across
        a typical 0.8-1 m door or corridor and keeps to its middle, while a free cell 0.1 m
        off the body costs floor(252 exp(-0.5)) = 152, not a wall the search cannot cross.
        Nav2's own defaults (0.55 m, 3-10 /m) are in the same range.
        """
        inscribed = robot.radius_m
        return cls(inscribed_radius_m=inscribed, inflation_radius_m=inscribed + 0.35,
                   cost_scaling_factor=5.0)


@dataclass(frozen=True)
class PlannerSettings:
    visit_sensitivity: float = 0.5   # extra cost per recorded visit of a cell (seed 001 uses 0.5)
    cost_weight: float = 1.0         # weight of the costmap value c / 252 in the step cost
    unknown_cost: int = -1           # cost of unknown cells (0..252); -1 forbids them
    shortcut: bool = True            # simplify the A* path by line of sight

    def validate(self, src: str) -> None:
        require(self.visit_sensitivity >= 0, src, "visit_sensitivity", "must be >= 0")
        require(self.cost_weight >= 0, src, "cost_weight", "must be >= 0")
        require(self.unknown_cost == -1 or 0 <= self.unknown_cost <= 252, src, "unknown_cost",
                "must be -1 (forbid unknown cells) or in 0..252")


def make_costmap(occupancy: np.ndarray, resolution: float, settings: CostmapSettings) -> np.ndarray:
    """Inflated uint8 costmap from an int8 occupancy grid (-1 unknown, 0..100).

    The distance field measures between cell centres, and both ends of a distance sit
    anywhere in their cells: an obstacle fills its cell, so its nearest point (a corner, seen
    diagonally) lies up to half a cell diagonal (res / sqrt 2) nearer than its centre; the
    robot's centre lies up to as far from the centre of the cell the planner and the follower
    check. Both radii are therefore applied one cell diagonal (res * sqrt 2) further out, so
    that a robot whose cell is outside the inscribed band keeps its body off the obstacle
    itself, from every direction (with half a cell, the burger grazed box corners).
    """
    margin = resolution * math.sqrt(2.0)
    return _native.inflate(occupancy, resolution, settings.inscribed_radius_m + margin,
                           settings.inflation_radius_m + margin, settings.cost_scaling_factor,
                           occupied_threshold=OCCUPIED_THRESH,
                           unknown_is_obstacle=settings.unknown_is_obstacle)


def cost_model(settings: PlannerSettings, resolution: float) -> dict:
    """The step cost arguments of ``_native.astar`` / ``dijkstra``: ``settings``, cells from
    INSCRIBED up impassable, ``resolution`` (m per cell) scaling the cost."""
    return dict(visit_sensitivity=settings.visit_sensitivity, cost_weight=settings.cost_weight,
                unknown_cost=settings.unknown_cost, lethal_cost=INSCRIBED, resolution=resolution)


def dijkstra(costmap: np.ndarray, start: Cell, resolution: float,
             settings: PlannerSettings = PlannerSettings(), visits: Optional[np.ndarray] = None,
             targets: Optional[np.ndarray] = None) -> np.ndarray:
    """The cost-to-come field from ``start`` on ``costmap`` (float32, m scaled by the step cost
    of ``settings``; +inf where unreachable); ``targets`` (int32 (n, 2)): stop once all are
    settled."""
    return _native.dijkstra(costmap, start, visits=visits, targets=targets,
                            **cost_model(settings, resolution))


def plan(costmap: np.ndarray, start: Cell, goal: Cell, settings: PlannerSettings,
         visits: Optional[np.ndarray] = None, resolution: float = 0.05) -> np.ndarray:
    """Cheapest path start -> goal on ``costmap`` as int32 (n, 2) cells, start and goal included.

    ``visits`` (int32, same shape) penalises revisiting cells; ``resolution`` (m) only scales
    the cost. Raises PlanningError naming the problem when there is no path.
    """
    start, goal = (int(start[0]), int(start[1])), (int(goal[0]), int(goal[1]))
    try:
        path, _ = _native.astar(costmap, start, goal, visits=visits, **cost_model(settings, resolution))
    except ValueError as exc:
        raise PlanningError(str(exc)) from exc
    if len(path) == 0:
        raise PlanningError(f"plan: goal {goal} is unreachable from start {start}")
    if settings.shortcut:
        path = _native.shortcut(path, costmap, lethal_cost=INSCRIBED)
    return path
