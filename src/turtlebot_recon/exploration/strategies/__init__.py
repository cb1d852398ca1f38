"""Goal selection strategies: one contract, one module, one class and one YAML block each.

A strategy looks at the current frontiers (``frontiers.Frontier``), a ``Context`` (robot
pose, time, grids, seeded RNG) and the shared ``GoalBook``, and returns the frontier to go
to (its ``goal`` / ``goal_cell`` being the point to send), or None when nothing is left.
Strategies never block, hold no clock (``ctx.now_s``) and draw randomness only from
``ctx.rng``. Every returned goal is a cell the robot can stand on (costmap <= ctx.max_cost)
and reach (finite ``ctx.cost_to_come``), and is not blacklisted.

| name                  | source    | rule                                                       |
|-----------------------|-----------|------------------------------------------------------------|
| nearest               | seed 001  | nearest accessible point of the nearest frontier           |
| density               | seed 003  | min (5 dist - frontier neighbours) / attempt weight        |
| gain_distance_heading | seed 004  | max 2.3 unknowns near - 2 dist + 5 cos(heading error)      |
| sampled               | seed 000  | 5 % random frontier cells, nearest or median; tags first   |
| explore_lite          | m-explore | min 3.0 d_min res - 1.0 size res, goal at the centroid     |
| recon (default)       | ours      | first goal of a tour over all clusters on path distances   |

Where a seed sent a point that is not a reachable cell (seed 003's unknown frontier cell,
explore_lite's centroid), the point is snapped to the nearest reachable cell within
``snap_radius_m`` (what the seeds' planners did implicitly: RRT to the nearest tree node,
move_base to the nearest plannable cell); a point with none is skipped. Such goals are
returned as a copy of their frontier with ``goal``, ``goal_cell`` and ``path_cost_m``
replaced (``gain`` stays the cluster's).

This module is the contract (``Context``, ``Strategy``) and the registry (``STRATEGIES``,
``make_strategy``, ``load_strategy``); each strategy lives in the module named after it,
with helpers used by several of them in ``common``. To add one: a module with a frozen
``Settings`` dataclass (``validate``) and a class with ``name``, ``Settings`` and ``choose``,
an entry in ``STRATEGIES``, a block in config/explorer.yaml and a test.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Dict, List, Optional, Protocol, Sequence, Tuple

import numpy as np
from scipy import ndimage

from ... import geometry
from ...config import ConfigError, from_dict
from ..frontiers import Frontier
from ..goals import GoalBook, GoalBookSettings
from .common import Cell, Point
from .density import Density
from .explore_lite import ExploreLite
from .gain_distance_heading import GainDistanceHeading
from .nearest import Nearest
from .recon import Recon
from .sampled import Sampled

__all__ = ["Context", "Strategy", "STRATEGIES", "DEFAULT_STRATEGY", "make_strategy",
           "load_strategy", "Nearest", "Density", "GainDistanceHeading", "Sampled",
           "ExploreLite", "Recon"]


@dataclass(frozen=True, eq=False)
class Context:
    """What a strategy may look at. Grids: nav_msgs/OccupancyGrid order (row 0 = smallest y)."""
    robot_xy: Point                   # m, map frame
    robot_yaw: float                  # rad, map frame
    now_s: float                      # s, the caller's clock (sim or ROS time)
    resolution: float                 # m per cell
    origin: Tuple[float, ...]         # (x, y[, yaw]) m of cell (0, 0)'s corner, yaw ignored
    occupancy: np.ndarray             # int8: -1 unknown, 0..100
    costmap: np.ndarray               # uint8 Nav2 costmap (253 inscribed, 254 lethal, 255 unknown)
    cost_to_come: np.ndarray          # float32 Dijkstra field from the robot (m, cost-weighted)
    visits: Optional[np.ndarray]      # int32 visit counts (seed 001), or None
    rng: np.random.Generator          # seeded by the caller
    max_cost: int = 252               # a goal cell must cost <= this (below inscribed)
    priority_goals: Tuple[Point, ...] = ()  # points to visit before frontiers (seed 000: tags)

    def xy_to_cell(self, xy: Sequence[float]) -> Cell:
        return geometry.xy_to_cell(xy, self.resolution, self.origin)

    def cell_to_xy(self, cell: Sequence[int]) -> Point:
        return geometry.cell_to_xy(cell, self.resolution, self.origin)

    @cached_property
    def reachable(self) -> np.ndarray:
        """Bool grid: a cell the robot can stand on and reach."""
        return np.isfinite(self.cost_to_come) & (self.costmap <= self.max_cost)

    @cached_property
    def _nearest_reachable(self) -> Optional[np.ndarray]:
        if not self.reachable.any():
            return None
        return ndimage.distance_transform_edt(~self.reachable, return_distances=False,
                                              return_indices=True)

    def goal_ok(self, cell: Sequence[int]) -> bool:
        r, c = int(cell[0]), int(cell[1])
        return geometry.inside(r, c, self.reachable.shape) and bool(self.reachable[r, c])

    def snap(self, xy: Sequence[float], radius_m: float) -> Optional[Cell]:
        """The reachable cell nearest ``xy`` (its centre within radius_m), or None."""
        index = self._nearest_reachable
        if index is None:
            return None
        rows, cols = self.reachable.shape
        r, c = self.xy_to_cell(xy)
        r, c = min(max(r, 0), rows - 1), min(max(c, 0), cols - 1)   # off the grid: its edge
        cell = (int(index[0][r, c]), int(index[1][r, c]))
        return cell if math.dist(self.cell_to_xy(cell), xy) <= radius_m + 1e-9 else None


class Strategy(Protocol):
    """What every strategy class provides: its YAML ``name``, a frozen ``Settings`` dataclass
    (its constructor's one argument) and ``choose``, which may update the strategy's own
    memory and the book (explore_lite blacklists) but never blocks."""
    name: str

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        ...


# ------------------------------------------------------------------ registry and configuration

STRATEGIES: Dict[str, type] = {cls.name: cls for cls in
                               (Nearest, Density, GainDistanceHeading, Sampled, ExploreLite, Recon)}
DEFAULT_STRATEGY = "recon"


def make_strategy(name: str, params: Optional[dict] = None, source: str = "explorer") -> Strategy:
    """Strategy ``name`` with ``params`` (its YAML block); ConfigError names any bad key."""
    if name not in STRATEGIES:
        raise ConfigError(f"{source}/strategy: unknown strategy {name!r}; "
                          f"known: {sorted(STRATEGIES)}")
    cls = STRATEGIES[name]
    if params is not None and not isinstance(params, dict):
        raise ConfigError(f"{source}/strategies/{name}: expected a mapping, got {params!r}")
    return cls(from_dict(cls.Settings, params or {}, f"{source}/strategies/{name}"))


def load_strategy(config: dict, source: str = "explorer") -> Tuple[Strategy, GoalBookSettings]:
    """The strategy named by ``config['strategy']`` (default recon) with its block from
    ``config['strategies']``, and the GoalBook settings from ``config['goals']``. Every
    strategy block is validated, not only the chosen one, so a typo anywhere fails loudly."""
    blocks = config.get("strategies") or {}
    if not isinstance(blocks, dict):
        raise ConfigError(f"{source}/strategies: expected a mapping, got {blocks!r}")
    unknown = sorted(set(blocks) - set(STRATEGIES))
    if unknown:
        raise ConfigError(f"{source}/strategies: unknown strategy block(s) {unknown}; known: "
                          f"{sorted(STRATEGIES)}")
    built = {name: make_strategy(name, block, source) for name, block in blocks.items()}
    name = config.get("strategy", DEFAULT_STRATEGY)
    strategy = built.get(name) or make_strategy(name, None, source)
    goals = from_dict(GoalBookSettings, config.get("goals") or {}, f"{source}/goals")
    return strategy, goals
