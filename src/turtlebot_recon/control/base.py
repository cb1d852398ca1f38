"""The controller contract: what every controller takes each control period and returns.

Every controller (the pure pursuit follower, DWA, the PD follower, MPPI, Tube MPPI) implements one
small contract, ``Controller``: ``reset()`` when a navigation goal starts or is cancelled, and
``compute(ControlInput) -> ControlOutput`` once per control period. The caller (the navigator)
owns time, TF, the global plan and replanning; a controller only turns the plan, the pose and
the map into one velocity command and a status:

- ``following``: driving along the path;
- ``rotating``:  turning in place, toward the path or, at the goal, to ``goal_yaw``;
- ``arrived``:   within the goal tolerances; zero command;
- ``blocked``:   the way ahead (or the robot's own cell) is in collision; zero command; replan;
- ``no_path``:   fewer than two usable waypoints; zero command.

Collisions are the robot's body (the oriented box, or a round robot's disc) against the
occupancy grid: every controller checks the poses it is about to drive through with
``footprint.BodyCheck`` (the planner's exact geometry, include/turtlebot_recon/footprint.hpp),
built once from the robot and its margin; the costmap is for grading (slowing down near
obstacles, a critic's cost), never for collisions.

Poses and paths are in the map frame (m, rad), velocities in the robot frame (REP-103: +x
forward, +w counter-clockwise). The occupancy grid is int8 (-1 unknown, 0..100, map_server's
threshold 65 for an obstacle); the costmap, on the same grid, follows the Nav2 convention (0
free .. 252 graded, 253 where no heading of the body fits, 254 lethal, 255 unknown); row 0 at
the smallest y, cell (r, c) centred at origin + ((c + 0.5) res, (r + 0.5) res).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Protocol, runtime_checkable

import numpy as np

FOLLOWING, ROTATING, ARRIVED, BLOCKED, NO_PATH = (
    "following", "rotating", "arrived", "blocked", "no_path")
STATUSES = (FOLLOWING, ROTATING, ARRIVED, BLOCKED, NO_PATH)


# eq=False: the fields hold numpy arrays, whose == is elementwise; inputs compare by identity.
@dataclass(frozen=True, eq=False)
class ControlInput:
    """One control period's inputs (map frame unless stated)."""
    now_s: float                 # time of this step (s); controllers with memory in time use it
    pose: tuple                  # (x m, y m, yaw rad)
    velocity: tuple              # measured (v m/s, w rad/s), robot frame
    path: np.ndarray             # float (n, 2) waypoints, start .. goal (the global plan): the
                                 # robot's position, then the ends of straight segments, at
                                 # which it may turn in place (a lattice plan's corners)
    goal_yaw: Optional[float]    # final heading wanted (rad), or None for any
    occupancy: np.ndarray        # int8 (rows, cols): -1 unknown, 0..100; collisions (BodyCheck)
    costmap: np.ndarray          # uint8 (rows, cols), Nav2 costs of the same grid; grading only
    resolution: float            # m per cell
    origin: tuple                # (x m, y m[, yaw]) of the grid's corner; yaw must be 0


@dataclass(frozen=True)
class ControlOutput:
    linear_mps: float
    angular_radps: float
    status: str                            # one of STATUSES
    lookahead: Optional[tuple] = None      # (x, y) map-frame target point, for markers
    detail: str = ""                       # why, for blocked / no_path (one clause, for logs)


@dataclass(frozen=True, eq=False)
class ControlMarkers:
    """What a sampling controller shows in rviz after a step (map frame): its chosen trajectory
    and a sample of its rollouts, each with a score in [0, 1] (1 best; NaN: rejected)."""
    trajectory: np.ndarray       # float (n, 3) poses (x, y, yaw) the command drives through
    rollouts: list               # float (m_i, 3) pose arrays, at most the sample asked for
    scores: np.ndarray           # float (len(rollouts),)


@runtime_checkable
class Controller(Protocol):
    def reset(self) -> None:
        """Forget the path and all progress along it (a new goal, or a cancel)."""

    def compute(self, inp: ControlInput) -> ControlOutput:
        """The velocity command for this period; never blocks, never returns NaN."""


    # Optional, for rviz: ``markers(max_rollouts) -> Optional[ControlMarkers]``, the last step's
    # trajectory and rollouts (the navigator node publishes them when someone listens).


class PeriodClock:
    """The control period (s) from the last two steps' times (``ControlInput.now_s``), for
    controllers that integrate over it: ``default_s`` until there are two, and when the clock
    stood still, jumped back or jumped by more than a second. ``reset()`` with the controller."""

    def __init__(self, default_s: float):
        self.default_s = default_s
        self.reset()

    def reset(self) -> None:
        self._last_s: Optional[float] = None

    def __call__(self, now_s) -> float:
        try:
            now = float(now_s)
        except (TypeError, ValueError):
            now = math.nan
        last, self._last_s = self._last_s, now
        dt = now - last if last is not None else math.nan
        return dt if math.isfinite(dt) and 0.0 < dt <= 1.0 else self.default_s
