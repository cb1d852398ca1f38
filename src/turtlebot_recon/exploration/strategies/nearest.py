"""nearest (seed 001): the nearest of the frontiers' nearest accessible points."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional

from ...config import positive
from ..context import Context
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import distance, reachable_only, with_goal


@dataclass(frozen=True)
class NearestSettings:
    snap_radius_m: float = 1.0   # how far the accessible point may be from the frontier cell

    def validate(self, src: str) -> None:
        positive(src, self, "snap_radius_m")


class Nearest:
    """Seed 001: go to the nearest of the frontiers' nearest accessible points.

    For each frontier, its cell nearest the robot (``closest``) is snapped to the nearest
    reachable cell (seed 001's "nearest accessible point": the robot's rim clears every
    obstacle); the destinations are ranked by Euclidean distance from the robot and the
    first with a path is taken ("if no valid path exists ..., the next closest frontier is
    evaluated").
    """
    name = "nearest"
    Settings = NearestSettings

    def __init__(self, settings: NearestSettings = NearestSettings()):
        self.settings = settings

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        best, best_key = None, None
        for f in reachable_only(frontiers):
            cell = ctx.snap(f.closest, self.settings.snap_radius_m)
            if cell is None or book.is_blacklisted(ctx.cell_to_xy(cell)):
                continue
            key = (distance(ctx.robot_xy, ctx.cell_to_xy(cell)),
                   distance(ctx.robot_xy, f.closest), f.id)
            if best_key is None or key < best_key:
                best, best_key = (f, cell), key
        return None if best is None else with_goal(best[0], best[1], ctx)
