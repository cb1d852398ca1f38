"""gain_distance_heading (seed 004): max 2.3 unknowns near - 2 dist + 5 cos(heading error)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from ...config import require
from ..context import Context
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import distance, heading_error, usable, window_around


@dataclass(frozen=True)
class GainDistanceHeadingSettings:
    unknown_weight: float = 2.3          # W_s, per unknown cell near the goal
    distance_weight_per_m: float = -2.0  # W_w, per metre robot -> goal (negative: nearer wins)
    heading_weight: float = 5.0          # W_theta, times cos(heading error)
    value_radius_cells: int = 2          # VALUE_RADIUS (unstated in seed 004): 5 x 5 window, so
                                         # a straight frontier's ~10 unknowns (23 points) weigh
                                         # like ~10 m of distance, the balance its weights intend
    top_clusters: int = 10               # only the largest clusters are scored (seed 004: 5-10)

    def validate(self, src: str) -> None:
        require(isinstance(self.value_radius_cells, int) and self.value_radius_cells >= 0, src,
                "value_radius_cells", "must be an integer >= 0")
        require(isinstance(self.top_clusters, int) and self.top_clusters >= 0, src,
                "top_clusters", "must be an integer >= 0 (0: all)")


class GainDistanceHeading:
    """Seed 004: score S = 2.3 x + (-2) y + 5 cos(theta), maximum.

    x = unknown cells within value_radius_cells of the goal point; y = Euclidean distance
    robot -> goal point (m, "3D distance from robot pose to frontier pose", z = 0); theta =
    angle between the robot's yaw and the vector robot -> goal. Only the ``top_clusters``
    largest clusters are scored; blacklisted goals are skipped (seed 004's blacklist).
    """
    name = "gain_distance_heading"
    Settings = GainDistanceHeadingSettings

    def __init__(self, settings: GainDistanceHeadingSettings = GainDistanceHeadingSettings()):
        self.settings = settings

    def score(self, f: Frontier, ctx: Context) -> float:
        s = self.settings
        window = window_around(ctx.occupancy, f.goal_cell, s.value_radius_cells)
        unknowns = int(np.count_nonzero(window < 0))
        return (s.unknown_weight * unknowns
                + s.distance_weight_per_m * distance(ctx.robot_xy, f.goal)
                + s.heading_weight * math.cos(heading_error(ctx, f.goal)))

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        cands = usable(frontiers, ctx, book)
        if self.settings.top_clusters > 0:
            cands = sorted(cands, key=lambda f: -f.size)[:self.settings.top_clusters]
        if not cands:
            return None
        scores = [self.score(f, ctx) for f in cands]
        return cands[int(np.argmax(scores))]
