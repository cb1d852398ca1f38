"""recon (ours, the default): the first goal of a short tour over all reachable clusters,
on path distances."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from ...config import positive, require
from .. import tour
from ..context import Context, Point
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import distance, heading_error, usable, window_around


@dataclass(frozen=True)
class ReconSettings:
    # Weights turn every term into metres of path, the unit of the tour.
    turn_weight_m_per_rad: float = 0.3     # ~2x the distance a TB3 drives while turning 1 rad
                                           # (v/omega = 0.26/1.82 = 0.14 m): turning also costs
                                           # the stop and the re-acceleration
    gain_weight_m_per_m2: float = 0.1      # a goal showing 10 m^2 more is worth a 1 m detour:
                                           # far below the 2 x 3.5 m^2 a lidar sweeps per metre
                                           # in the open, so gain breaks ties, not the tour
    visit_weight_m_per_visit: float = 0.5  # per pass already driven near the goal: a frontier
                                           # that survived passes is likely a sensor shadow
    visit_radius_m: float = 0.5            # "near the goal" for the visit count
    use_tour: bool = True                  # order all clusters as a tour (false: least first leg)
    tour_max_clusters: int = 20            # the cheapest first legs enter the tour (n Dijkstras)
    tour_cell_m: float = 0.1               # m, cells of the goal-to-goal Dijkstras: the map's
                                           # coarsened by round(this / resolution), at least 1
                                           # (4x fewer cells at 0.05 m)
    hysteresis_m: float = 1.0              # keep the last goal unless the new tour is this much
    hysteresis_ratio: float = 0.1          # ... or this fraction shorter (the larger of the two)
    match_radius_m: float = 0.5            # the last goal "is still there" within this radius

    def validate(self, src: str) -> None:
        for key in ("turn_weight_m_per_rad", "gain_weight_m_per_m2", "visit_weight_m_per_visit",
                    "hysteresis_m", "hysteresis_ratio"):
            require(getattr(self, key) >= 0, src, key, "must be >= 0")
        positive(src, self, "visit_radius_m", "match_radius_m", "tour_cell_m")
        require(isinstance(self.tour_max_clusters, int) and self.tour_max_clusters >= 1, src,
                "tour_max_clusters", "must be an integer >= 1")


class Recon:
    """Ours: the first goal of a short tour through every reachable cluster.

    First leg (robot -> goal i), in metres of path:
        leg_i = path_cost_i + turn_weight * |heading error_i|
                + visit_weight * visits_i - gain_weight * gain_area_i
    path_cost from the Dijkstra field (not Euclidean: walls count); heading error to the
    goal's straight-line bearing; visits = most passes recorded within visit_radius_m of the
    goal; gain_area = gain cells * resolution^2. Between goals: Dijkstra path distances on
    tour_cell_m cells (``tour.path_distance_matrix``). The clusters are ordered by nearest
    insertion + 2-opt from the robot (``tour.solve``) and the first is chosen, so the robot
    finishes one end of the building before crossing to the other. Hysteresis: the last goal
    is kept while the best tour that starts with it is at most max(hysteresis_m,
    hysteresis_ratio * |best|) longer than the best tour.

    Candidates: usable goals (reachable, affordable, not blacklisted; a frontier that
    survived an arrival at its goal comes with another viewpoint as its goal, see
    ``viewpoints``); the tour_max_clusters cheapest first legs enter the tour. Small gains
    are not set aside for later: a small frontier (a dead end's last cells, a corner) costs
    little while the robot is near it and a long trip back at the end (keeping gains under
    0.1 m^2 for last cost about 20 % of the time to 99 % in the maze).
    """
    name = "recon"
    Settings = ReconSettings

    def __init__(self, settings: ReconSettings = ReconSettings()):
        self.settings = settings
        self.last_goal: Optional[Point] = None
        self.last_tour: List[Point] = []   # goals in tour order, for display

    def first_leg(self, f: Frontier, ctx: Context) -> float:
        s = self.settings
        visits = 0
        if ctx.visits is not None:
            k = int(math.ceil(s.visit_radius_m / ctx.resolution))
            window = window_around(ctx.visits, f.goal_cell, k)
            visits = int(window.max()) if window.size else 0
        return (f.path_cost_m + s.turn_weight_m_per_rad * heading_error(ctx, f.goal)
                + s.visit_weight_m_per_visit * visits
                - s.gain_weight_m_per_m2 * f.gain * ctx.resolution ** 2)

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        s = self.settings
        cands = usable(frontiers, ctx, book)
        if not cands:
            self.last_goal, self.last_tour = None, []
            return None
        legs = np.array([self.first_leg(f, ctx) for f in cands])
        keep = np.argsort(legs, kind="stable")[:s.tour_max_clusters]
        cands, legs = [cands[i] for i in keep], legs[keep]
        if not s.use_tour or len(cands) == 1:
            order = list(range(len(cands)))
            pick = 0
        else:
            factor = max(1, int(round(s.tour_cell_m / ctx.resolution)))
            D = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come,
                                          [f.goal_cell for f in cands], ctx.resolution, factor)
            D[0, 1:] = legs
            D = tour.prepare(D)
            best = tour.solve(D)
            order = [i - 1 for i in best[1:]]
            pick = self._hysteresis(order[0], tour.length(D, best), D, cands)
            if pick != order[0]:
                order.remove(pick)
                order.insert(0, pick)
        self.last_goal = cands[pick].goal
        self.last_tour = [cands[i].goal for i in order]
        return cands[pick]

    def _hysteresis(self, pick: int, best_m: float, D: np.ndarray, cands: List[Frontier]) -> int:
        """Index of the last goal if it is still a candidate and nearly as good, else pick."""
        s = self.settings
        if self.last_goal is None:
            return pick
        dist = [distance(self.last_goal, f.goal) for f in cands]
        last = int(np.argmin(dist))
        if dist[last] > s.match_radius_m or last == pick:
            return pick
        node = last + 1                    # forced first: solve the rest from there
        rest = [node] + [i for i in range(1, len(D)) if i != node]
        sub = D[np.ix_(rest, rest)]
        forced_m = D[0, node] + tour.length(sub, tour.solve(sub))
        margin = max(s.hysteresis_m, s.hysteresis_ratio * abs(best_m))
        return last if forced_m <= best_m + margin else pick
