"""Helpers shared by several goal strategies: candidate filters, moving a goal, geometry."""
from __future__ import annotations

import dataclasses
import math
from typing import List, Sequence

import numpy as np

from ...geometry import wrap_angle
from ..context import Cell, Context
from ..frontiers import Frontier
from ..goals import GoalBook


def reachable_only(frontiers: Sequence[Frontier]) -> List[Frontier]:
    """The clusters the frontier search found a goal for (``Frontier.reachable``): the others
    (given up, or waiting behind a gap) are never chased, whatever point a strategy would
    pick in them."""
    return [f for f in frontiers if f.reachable]


def usable(frontiers: Sequence[Frontier], ctx: Context, book: GoalBook) -> List[Frontier]:
    """Frontiers whose own goal is reachable, affordable, not blacklisted and not found
    unreachable by the navigator on the map as it is (``GoalBook.is_unreachable``)."""
    return [f for f in frontiers
            if f.reachable and ctx.goal_ok(f.goal_cell) and not book.is_blacklisted(f.goal)
            and not book.is_unreachable(f.goal, ctx)]


def with_goal(frontier: Frontier, cell: Cell, ctx: Context) -> Frontier:
    """``frontier`` with its goal moved to the reachable ``cell``."""
    cell = (int(cell[0]), int(cell[1]))
    return dataclasses.replace(frontier, goal=ctx.cell_to_xy(cell), goal_cell=cell,
                               path_cost_m=float(ctx.cost_to_come[cell]), reachable=True)


def distance(a: Sequence[float], b: Sequence[float]) -> float:
    """Euclidean distance (m) between two points of the map frame."""
    return math.hypot(b[0] - a[0], b[1] - a[1])


def heading_error(ctx: Context, xy: Sequence[float]) -> float:
    """|angle| (rad, 0..pi) between the robot's heading and the direction to ``xy``."""
    dx, dy = xy[0] - ctx.robot_xy[0], xy[1] - ctx.robot_xy[1]
    if math.hypot(dx, dy) < 1e-9:
        return 0.0
    err = math.atan2(dy, dx) - ctx.robot_yaw
    return abs(wrap_angle(err))


def window_around(grid: np.ndarray, cell: Cell, k: int) -> np.ndarray:
    """The (2k + 1)^2 square of ``grid`` centred on ``cell``, cut at the grid's edges (a view)."""
    r, c = cell
    return grid[max(r - k, 0):r + k + 1, max(c - k, 0):c + k + 1]
