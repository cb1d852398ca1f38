"""The robot's body against the occupancy grid: the collision check every controller makes.

The planner (planning.lattice) plans the oriented footprint with its own margin; a controller
checks the poses it is about to pass through against the same occupancy grid with the same
exact geometry (include/turtlebot_recon/footprint.hpp: the box, or a round robot's disc,
measured to the obstacle cells' squares), with a smaller margin of its own, since the robot
follows the plan only to within a centimetre or so.

- ``clearance`` / ``clear``: the body at any (x, y, yaw) poses;
- ``disc_clear``: the turning disc (the circumscribed radius about base_footprint) at points:
  where it fits, every heading does;
- ``turn_clear``: turning in place by an angle: the disc fits, or the box keeps
  ``margin_m + SWEEP_EXTRA_M`` at every yaw of the sweep, sampled every ``SWEEP_STEP_RAD``.

Grids follow ControlInput: int8 occupancy (-1 unknown, 0..100), row 0 at the smallest y,
``origin`` the (x, y) of cell (0, 0)'s corner. Unknown cells and cells off the grid are no
obstacles to the body (the planner's convention); a controller decides about unknown cells under
the robot's centre itself.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _native
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import RobotSpec, footprint_args

SWEEP_STEP_RAD = math.radians(1.0)   # yaw samples of an in-place turn: a corner 0.257 m out
                                     # moves 4.5 mm between them...
SWEEP_EXTRA_M = 0.005                # ...so the sweep keeps this much more than margin_m


@dataclass(frozen=True)
class BodyCheck:
    robot: RobotSpec
    margin_m: float = 0.005           # body to obstacle edge below which a pose collides
                                      # (FollowerSettings.collision_margin_m)
    occupied_threshold: int = OCCUPIED_THRESH   # occupancy (0..100) >= this is an obstacle

    def _args(self, round_body: bool) -> dict:
        if round_body:
            return dict(footprint_args(self.robot), footprint_length_m=0.0, footprint_width_m=0.0,
                        footprint_offset_x_m=0.0)
        return footprint_args(self.robot)

    def clearance(self, inp, poses, max_m: float, disc: bool = False) -> np.ndarray:
        """float (n,): metres from the body (``disc``: the turning disc) at each (x, y, yaw) of
        ``poses`` to the nearest obstacle square of ``inp.occupancy``, capped at ``max_m``."""
        return _native.footprint_clearance(
            np.asarray(inp.occupancy, dtype=np.int8), float(inp.resolution),
            (float(inp.origin[0]), float(inp.origin[1])),
            np.asarray(poses, dtype=float).reshape(-1, 3), **self._args(disc), max_m=max_m,
            occupied_threshold=self.occupied_threshold, unknown_is_obstacle=False)

    def clear(self, inp, poses) -> np.ndarray:
        """bool (n,): the body keeps ``margin_m`` off every obstacle at each pose."""
        return self.clearance(inp, poses, self.margin_m) >= self.margin_m

    def stays_clear(self, inp, poses) -> bool:
        """Whether a motion through ``poses`` (the first where the robot is) keeps ``margin_m``
        off every obstacle, or at least gets no nearer to them than it starts (a robot already
        brushing a wall may move away from it)."""
        clearance = self.clearance(inp, poses, self.margin_m)
        return bool((clearance >= np.minimum(self.margin_m, clearance[0]) - 1e-9).all())

    def disc_clear(self, inp, xy, extra_m: float = 0.0) -> np.ndarray:
        """bool (n,): the turning disc keeps ``margin_m + extra_m`` off every obstacle at each
        (x, y) of ``xy``."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        need = self.margin_m + extra_m
        poses = np.column_stack([xy, np.zeros(len(xy))])
        return self.clearance(inp, poses, need, disc=True) >= need

    def turn_clear(self, inp, pose, turn_rad: float) -> bool:
        """Whether turning in place at ``pose`` by ``turn_rad`` (signed) is safe: the disc fits,
        or the box keeps margin_m + SWEEP_EXTRA_M at every sampled yaw of the sweep. A robot
        already nearer than that may turn if no yaw of the sweep brings it nearer still."""
        x, y, yaw = (float(v) for v in pose[:3])
        if self.robot.is_round or self.disc_clear(inp, [(x, y)])[0]:
            return True
        n = max(1, int(math.ceil(abs(turn_rad) / SWEEP_STEP_RAD)))
        yaws = yaw + turn_rad * np.arange(n + 1) / n
        poses = np.column_stack([np.full(n + 1, x), np.full(n + 1, y), yaws])
        need = self.margin_m + SWEEP_EXTRA_M
        clr = self.clearance(inp, poses, need)
        return bool((clr >= min(need, clr[0]) - 1e-9).all())
