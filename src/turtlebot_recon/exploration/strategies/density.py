"""density (seed 003): min (5 dist - frontier neighbours) / attempt weight over its own
frontier cells."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np
from scipy.spatial import cKDTree

from ...config import positive, require
from ...geometry import cells_to_points
from ...mapping.map_io import FREE_THRESH, OCCUPIED_THRESH
from ..context import Context
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import reachable_only, with_goal


def _box_count(mask: np.ndarray, k: int) -> np.ndarray:
    """Number of True cells in the (2k + 1)^2 window around every cell (integral image)."""
    rows, cols = mask.shape
    s = np.zeros((rows + 1, cols + 1), dtype=np.int64)
    s[1:, 1:] = mask.astype(np.int64).cumsum(0).cumsum(1)
    r, c = np.arange(rows), np.arange(cols)
    r0, r1 = np.clip(r - k, 0, rows), np.clip(r + k + 1, 0, rows)
    c0, c1 = np.clip(c - k, 0, cols), np.clip(c + k + 1, 0, cols)
    return (s[np.ix_(r1, c1)] - s[np.ix_(r0, c1)] - s[np.ix_(r1, c0)] + s[np.ix_(r0, c0)])



@dataclass(frozen=True)
class DensitySettings:
    distance_weight_per_m: float = 5.0   # HEUR_DISTANCE_WEIGHT: 5 per metre vs 5..50 neighbours
    frontier_radius_cells: int = 8       # FRONTIER_RADIUS: neighbourhood half-width (cells)
    clear_neighbours_min: int = 5        # CLEAR_NEIGHBOR_FRONTIER_THRESH: need more clear cells
    weight_decrement: float = 0.2        # FRONTIER_WEIGHT_DECREMENT per failure nearby
    weight_min: float = 0.01             # the weight's floor (no division by 0)
    weight_radius_m: float = 0.4         # failures this close lower a cell's weight (8 cells)
    snap_radius_m: float = 0.6           # seed 003's cells lie up to 8 cells inside unknown
    max_candidates: int = 500            # cheapest cells tried for a reachable goal

    def validate(self, src: str) -> None:
        positive(src, self, "frontier_radius_cells", "weight_decrement", "weight_min",
                 "weight_radius_m", "snap_radius_m", "max_candidates")
        require(self.clear_neighbours_min >= 0, src, "clear_neighbours_min", "must be >= 0")
        require(self.weight_min <= 1.0, src, "weight_min", "must be <= 1")


class Density:
    """Seed 003: cost = (DIST_WEIGHT * dist - frontier_neighbours) / attempt_weight, minimum.

    Its own frontier cells: UNEXPLORED cells (neither clear nor blocked) with more than 5
    clear and no blocked cells within 8 cells. frontier_neighbours = the other such cells
    within 8 cells; dist = Euclidean robot -> cell (m; the seed's 5 per unit balances 5..50
    neighbours, so metres); attempt_weight = 1 - 0.2 per failure within weight_radius_m,
    floored at 0.01 (``GoalBook.attempt_weight``). Windows are squares of half-width 8.
    Faithful quirk: dividing a negative cost (a dense cell) by a smaller weight makes it
    MORE attractive after failures; only positive costs are pushed away.
    """
    name = "density"
    Settings = DensitySettings

    def __init__(self, settings: DensitySettings = DensitySettings()):
        self.settings = settings

    def frontier_cells(self, occupancy: np.ndarray) -> np.ndarray:
        """Bool grid of seed 003's frontier cells."""
        s = self.settings
        occ = np.asarray(occupancy)
        clear = (occ >= 0) & (occ <= FREE_THRESH)   # map_saver's free
        blocked = occ >= OCCUPIED_THRESH                 # between free and this: unexplored
        unexplored = ~clear & ~blocked
        k = s.frontier_radius_cells
        return (unexplored & (_box_count(clear, k) > s.clear_neighbours_min)
                & (_box_count(blocked, k) == 0))

    def costs(self, ctx: Context, book: GoalBook) -> Tuple[np.ndarray, np.ndarray]:
        """(cells int (n, 2), cost (n,)) of every seed-003 frontier cell."""
        s = self.settings
        mask = self.frontier_cells(ctx.occupancy)
        cells = np.argwhere(mask)
        if len(cells) == 0:
            return cells, np.zeros(0)
        neighbours = _box_count(mask, s.frontier_radius_cells)[mask] - 1    # not itself
        xy = cells_to_points(cells, ctx.resolution, ctx.origin)
        dist = np.hypot(xy[:, 0] - ctx.robot_xy[0], xy[:, 1] - ctx.robot_xy[1])
        failures = book.failure_points()
        nearby = np.zeros(len(cells))
        if len(failures):
            d = np.hypot(xy[:, None, 0] - failures[None, :, 0],
                         xy[:, None, 1] - failures[None, :, 1])
            nearby = (d <= s.weight_radius_m + 1e-9).sum(axis=1)
        weight = np.maximum(s.weight_min, 1.0 - s.weight_decrement * nearby)
        return cells, (s.distance_weight_per_m * dist - neighbours) / weight

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        frontiers = reachable_only(frontiers)
        if not frontiers:
            return None
        cells, cost = self.costs(ctx, book)
        if len(cells) == 0:
            return None
        owner_cells = np.concatenate([f.cells for f in frontiers]).astype(float)
        owner = np.repeat(np.arange(len(frontiers)), [len(f.cells) for f in frontiers])
        tree = cKDTree(owner_cells)
        for i in np.argsort(cost, kind="stable")[:self.settings.max_candidates]:
            xy = ctx.cell_to_xy(cells[i])
            goal = ctx.snap(xy, self.settings.snap_radius_m)
            if goal is None or book.is_blacklisted(ctx.cell_to_xy(goal)):
                continue
            _, j = tree.query(cells[i].astype(float))
            return with_goal(frontiers[int(owner[j])], goal, ctx)
        return None
