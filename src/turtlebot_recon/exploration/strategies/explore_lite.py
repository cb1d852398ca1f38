"""explore_lite (hrnr/m-explore): min 3.0 d_min res - 1.0 size res, goal at the centroid."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional

from ...config import positive, require
from ..context import Context, Point
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import distance, reachable_only, with_goal


@dataclass(frozen=True)
class ExploreLiteSettings:
    potential_scale: float = 3.0          # its explore.launch value (weight of the distance)
    gain_scale: float = 1.0               # its explore.launch value (weight of the length)
    min_frontier_size_m: float = 0.75     # its explore.launch min_frontier_size
    progress_timeout_s: float = 30.0      # its progress_timeout
    blacklist_tolerance_cells: int = 5    # its goalOnBlacklist square: |dx|, |dy| < 5 cells
    snap_radius_m: float = 1.0            # the centroid -> nearest reachable cell (move_base)

    def validate(self, src: str) -> None:
        require(self.potential_scale >= 0 and self.gain_scale >= 0, src, "potential_scale",
                "potential_scale and gain_scale must be >= 0")
        require(self.min_frontier_size_m >= 0, src, "min_frontier_size_m", "must be >= 0")
        positive(src, self, "progress_timeout_s", "blacklist_tolerance_cells", "snap_radius_m")


class ExploreLite:
    """explore_lite (hrnr/m-explore, ROS 1), frontier_search.cpp + explore.cpp, faithfully:

        cost = potential_scale * min_distance * resolution - gain_scale * size * resolution

    min_distance is already in metres (Euclidean, robot -> the frontier's closest cell,
    from mapToWorld coordinates) and is multiplied by the resolution again: a units bug, so
    at 0.05 m the distance weighs 3.0 * 0.05 = 0.15 per metre against 1.0 per metre of
    frontier length. Frontiers shorter than min_frontier_size (size * resolution < 0.75 m)
    are dropped; the cheapest frontier whose centroid is not within 5 cells (square) of a
    blacklisted goal is pursued, and the goal sent is the centroid itself. If the goal is
    unchanged and min_distance has not decreased for progress_timeout, the centroid is
    blacklisted and the next frontier taken. Its blacklist is permanent: expired entries
    still count here. ``orientation_scale`` is read by explore_lite but never used, so it
    is not a parameter here.

    Deliberate differences: the centroid is snapped to the nearest reachable cell, and a
    frontier without one (or flagged unreachable) is skipped rather than sent to fail in
    move_base (which explore_lite then blacklists: the same end). explore_lite's own
    centroid divides the sum of all cells but the first by the count of all of them (a
    bias of 1/size toward the map origin); ``Frontier.centroid`` is the true mean.
    """
    name = "explore_lite"
    Settings = ExploreLiteSettings

    def __init__(self, settings: ExploreLiteSettings = ExploreLiteSettings()):
        self.settings = settings
        self._prev_goal: Optional[Point] = None
        self._prev_distance_m = 0.0
        self._last_progress_s = -math.inf

    def cost(self, f: Frontier, ctx: Context) -> float:
        s = self.settings
        min_distance = distance(ctx.robot_xy, f.closest)
        return (s.potential_scale * min_distance * ctx.resolution
                - s.gain_scale * f.size * ctx.resolution)

    def _blacklisted(self, xy: Point, ctx: Context, book: GoalBook) -> bool:
        tol = self.settings.blacklist_tolerance_cells * ctx.resolution
        return book.is_blacklisted(xy, tol, chebyshev=True, include_expired=True)

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        s = self.settings
        long_enough = [f for f in reachable_only(frontiers)
                       if f.size * ctx.resolution >= s.min_frontier_size_m - 1e-9]
        ranked = sorted(long_enough, key=lambda f: self.cost(f, ctx))
        while True:
            pick = None
            for f in ranked:
                if self._blacklisted(f.centroid, ctx, book):
                    continue
                cell = ctx.snap(f.centroid, s.snap_radius_m)
                if cell is not None and not self._blacklisted(ctx.cell_to_xy(cell), ctx, book):
                    pick = (f, cell)
                    break
            if pick is None:
                return None
            f, cell = pick
            min_distance = distance(ctx.robot_xy, f.closest)
            same_goal = (self._prev_goal is not None
                         and distance(self._prev_goal, f.centroid) < 1e-9)
            self._prev_goal = f.centroid
            if not same_goal or self._prev_distance_m > min_distance:
                self._last_progress_s, self._prev_distance_m = ctx.now_s, min_distance
            if ctx.now_s - self._last_progress_s > s.progress_timeout_s:
                book.blacklist(f.centroid, ctx.now_s)
                continue
            return with_goal(f, cell, ctx)
