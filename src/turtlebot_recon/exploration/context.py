"""What a goal strategy may look at: the ``Context`` of one decision (robot pose, time, grids,
seeded RNG), built by the explorer and read by the strategies, the goal book and the tag search.

A contract of its own, apart from the strategies' package: the goal book and the tag search use
it without importing any strategy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from .. import geometry

Point = Tuple[float, float]
Cell = Tuple[int, int]


@dataclass(frozen=True)
class Motion:
    """Seconds of driving, as the navigator drives: its lattice's cruise speed and in-place turn
    rate (``LatticeSettings.with_robot``: the cost field's metres are metres at cruise speed,
    turns included), the robot's acceleration, and its speed now. Goals are chosen and costed
    with it, so the explorer and the controller agree on what "near" means."""
    cruise_mps: float                 # m/s, the lattice's cruise speed (the robot's top speed)
    turn_radps: float                 # rad/s, the lattice's (and the controllers') in-place turn rate
    accel_mps2: float                 # m/s^2, the robot's linear acceleration limit
    speed_mps: float = 0.0            # m/s, the robot's speed now (0: standing)

    @classmethod
    def of(cls, robot, lattice, speed_mps: float = 0.0) -> "Motion":
        """From a ``RobotSpec`` and the navigator's ``LatticeSettings``."""
        lattice = lattice.with_robot(robot)
        return cls(lattice.cruise_speed_mps, lattice.turn_speed_radps, robot.max_linear_accel_mps2,
                   abs(float(speed_mps)))

    def path_s(self, cost_m) -> float:
        """Seconds to drive a lattice cost of ``cost_m`` (metres at cruise speed, turns included)."""
        return cost_m / self.cruise_mps

    def turn_s(self, angle_rad: float) -> float:
        """Seconds to turn in place by ``angle_rad``."""
        return abs(angle_rad) / self.turn_radps

    @property
    def stop_s(self) -> float:
        """Seconds a stop costs at the present speed: braking from v and accelerating back to it
        at ``accel_mps2`` take 2 v / a, and cover v^2 / a, which at v take v / a: v / a lost."""
        return self.speed_mps / self.accel_mps2

    @property
    def stopping_distance_m(self) -> float:
        """Metres the robot needs to stop from its present speed: v^2 / 2a."""
        return self.speed_mps ** 2 / (2.0 * self.accel_mps2)


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
    motion: Optional[Motion] = None   # seconds of driving (the explorer always gives it; recon
                                      # needs it, the seeds' strategies cost in metres)

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
