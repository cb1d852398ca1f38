"""sampled (seed 000): 5 % random frontier cells, the nearest or the median one; tags first."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from ...config import positive, require
from ..context import Context
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import distance, reachable_only, with_goal


@dataclass(frozen=True)
class SampledSettings:
    sample_fraction: float = 0.05   # share of frontier cells drawn at random (seed 000: 5 %)
    min_samples: int = 1            # draw at least this many
    selection: str = "nearest"      # "nearest" or "median": the sample nearest the median distance
    snap_radius_m: float = 0.6      # a sampled cell's goal is the nearest reachable cell this close
    priority_goals: bool = True     # visit ctx.priority_goals (tags) before frontiers (seed 000)

    def validate(self, src: str) -> None:
        require(0.0 < self.sample_fraction <= 1.0, src, "sample_fraction", "must be in (0, 1]")
        require(isinstance(self.min_samples, int) and self.min_samples >= 1, src, "min_samples",
                "must be an integer >= 1")
        require(self.selection in ("nearest", "median"), src, "selection",
                f"must be 'nearest' or 'median', got {self.selection!r}")
        positive(src, self, "snap_radius_m")


class Sampled:
    """Seed 000: sample 5 % of the frontier cells at random, take the nearest sample (or the
    one whose distance is nearest the samples' median), Euclidean from the robot.

    Samples are tried in that order until one snaps to a reachable, non-blacklisted cell.
    With ``priority_goals``, the nearest reachable point of ``ctx.priority_goals`` (tags seen
    but not yet confirmed) comes first: seed 000 "prioritizes AprilTags as goals". Its goal
    reset near obstacles is ``GoalBook.reevaluate_reason`` ("blocked").
    """
    name = "sampled"
    Settings = SampledSettings

    def __init__(self, settings: SampledSettings = SampledSettings()):
        self.settings = settings

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        s = self.settings
        if s.priority_goals and ctx.priority_goals:
            tag = self._priority(ctx, book)
            if tag is not None:
                return tag
        frontiers = reachable_only(frontiers)
        if not frontiers:
            return None
        cells = np.concatenate([f.cells for f in frontiers])
        owner = np.repeat(np.arange(len(frontiers)), [len(f.cells) for f in frontiers])
        n = len(cells)
        k = min(n, max(s.min_samples, int(math.ceil(s.sample_fraction * n - 1e-9))))
        picked = ctx.rng.choice(n, size=k, replace=False)
        xy = [ctx.cell_to_xy(cells[i]) for i in picked]
        dist = np.array([distance(ctx.robot_xy, p) for p in xy])
        key = dist if s.selection == "nearest" else np.abs(dist - np.median(dist))
        for j in np.argsort(key, kind="stable"):
            goal = ctx.snap(xy[j], s.snap_radius_m)
            if goal is not None and not book.is_blacklisted(ctx.cell_to_xy(goal)):
                return with_goal(frontiers[int(owner[picked[j]])], goal, ctx)
        return None

    def _priority(self, ctx: Context, book: GoalBook) -> Optional[Frontier]:
        for p in sorted(ctx.priority_goals, key=lambda p: distance(ctx.robot_xy, p)):
            goal = ctx.snap(p, self.settings.snap_radius_m)
            if goal is None or book.is_blacklisted(ctx.cell_to_xy(goal)):
                continue
            xy = ctx.cell_to_xy(goal)
            return Frontier(id=-1, cells=np.zeros((0, 2), dtype=np.int32), size=0, length_m=0.0,
                            centroid=(float(p[0]), float(p[1])), closest=(float(p[0]), float(p[1])),
                            goal=xy, goal_cell=goal, gain=0,
                            path_cost_m=float(ctx.cost_to_come[goal]), reachable=True)
        return None
