"""recon (ours, the default): the first goal of a short tour over all reachable clusters, in
seconds of driving, committed to until a map event shows a faster tour."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np
from scipy.spatial import cKDTree

from ...config import positive, require
from .. import tour
from ..context import Context, Point
from ..frontiers import Frontier
from ..goals import GoalBook
from .common import heading_error, usable, window_around, with_goal


@dataclass(frozen=True)
class ReconSettings:
    # Gain and visits are priced in metres of path, driven at the lattice's cruise speed.
    gain_weight_m_per_m2: float = 0.1      # a goal showing 10 m^2 more is worth a 1 m detour:
                                           # far below the 2 x 3.5 m^2 a lidar sweeps per metre
                                           # in the open, so gain breaks ties, not the tour
    visit_weight_m_per_visit: float = 0.5  # per pass already driven near the goal: a frontier
                                           # that survived passes is likely a sensor shadow
    visit_radius_m: float = 0.5            # "near the goal" for the visit count
    use_tour: bool = True                  # order all clusters as a tour (false: least first leg)
    tour_max_clusters: int = 20            # clusters in a tour (one Dijkstra each): the first half
                                           # of the last tour's, then the cheapest first legs
    tour_cell_m: float = 0.1               # m, cells of the goal-to-goal Dijkstras: the map's
                                           # coarsened by round(this / resolution), at least 1
                                           # (4x fewer cells at 0.05 m)

    def validate(self, src: str) -> None:
        for key in ("gain_weight_m_per_m2", "visit_weight_m_per_visit"):
            require(getattr(self, key) >= 0, src, key, "must be >= 0")
        positive(src, self, "visit_radius_m", "tour_cell_m")
        require(isinstance(self.tour_max_clusters, int) and self.tour_max_clusters >= 1, src,
                "tour_max_clusters", "must be an integer >= 1")


class Recon:
    """Ours: the first goal of a short tour through every reachable cluster, in seconds.

    First leg (robot -> goal i), in seconds (``ctx.motion``, the navigator's lattice speeds):
        leg_i = (path_cost_i + visit_weight * visits_i - gain_weight * gain_area_i) / cruise
                + |heading error_i| / turn rate
    path_cost from the lattice's cost field (walls count, turns on the way included: metres at
    cruise speed); heading error to the goal's straight-line bearing (the field starts the
    robot at whichever heading suits it); visits = most passes recorded within visit_radius_m
    of the goal; gain_area = gain cells * resolution^2. Between goals: Dijkstra path distances
    on tour_cell_m cells (``tour.path_distance_matrix``) at cruise speed. The clusters are
    ordered by nearest insertion + 2-opt from the robot (``tour.solve``) and the first is
    chosen, so the robot finishes one end of the building before crossing to the other.

    Commitment: the goal being pursued (``book.active``; its cluster is the candidate holding
    most of its frontier cells) is kept, and no tour is planned, until a map event: a cluster
    born or gone (no cluster of the last plan within ``reevaluate_radius_m`` of it, or the
    reverse) or the pursued cluster's gain halved. (The explorer drops the goal when it is
    reached, its frontier is seen, it is blocked or cut off.) The tour outlives its first goal:
    at an event, and after a drop or an arrival, the last tour is brought up to date (its
    remaining clusters in its order, the pursued one first, new ones inserted where they add
    least, 2-opt behind the first) and followed unless a fresh tour is faster by more than
    what leaving it costs: stopping from the present speed and turning to face the new first
    goal (``Motion.stop_s`` + ``Motion.turn_s`` of its heading error); and never when the
    followed tour's first goal is nearer than that in time (arriving costs less than turning
    away). Tours re-solved from scratch at every cycle swung between the two ends of a ring of
    frontiers (goals 7 m apart in consecutive seconds in the arena).

    Candidates: usable goals (reachable, affordable, not blacklisted, not found unreachable on
    an unchanged map; a frontier that survived an arrival at its goal comes with another
    viewpoint as its goal, see ``viewpoints``); at most tour_max_clusters enter the tour: the
    first half of the last tour's remaining clusters, in its order, then the cheapest first
    legs (the tour's tail beyond that is planned again when the robot gets there: a tour kept
    whole grew with every cluster the map gained, to 130 Dijkstras a cycle, 3-5 s of wall
    time, in the 1,280 m^2 warehouse, and the robot stood through half of the run). Small
    gains are not set aside for later: a small frontier (a dead end's last cells, a corner) costs little while the robot
    is near it and a long trip back at the end (keeping gains under 0.1 m^2 for last cost
    about 20 % of the time to 99 % in the maze).
    """
    name = "recon"
    Settings = ReconSettings

    def __init__(self, settings: ReconSettings = ReconSettings()):
        self.settings = settings
        self.last_tour: List[Point] = []   # goals in tour order, for display
        self.plans = 0                     # tours planned (decisions at map events)
        self._clusters: List[np.ndarray] = []   # the last plan's candidates' frontier points
        self._tour: List[np.ndarray] = []       # ... and its tour's, in order
        self._pursued_gain = 0               # the pursued cluster's gain at the last plan

    def first_leg(self, f: Frontier, ctx: Context) -> float:
        """Seconds from the robot to ``f``'s goal (class docstring)."""
        s, motion = self.settings, _motion(ctx)
        visits = 0
        if ctx.visits is not None:
            k = int(np.ceil(s.visit_radius_m / ctx.resolution))
            window = window_around(ctx.visits, f.goal_cell, k)
            visits = int(window.max()) if window.size else 0
        metres = (f.path_cost_m + s.visit_weight_m_per_visit * visits
                  - s.gain_weight_m_per_m2 * f.gain * ctx.resolution ** 2)
        return motion.path_s(metres) + motion.turn_s(heading_error(ctx, f.goal))

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        s = self.settings
        cands = usable(frontiers, ctx, book)
        if not cands:
            self.last_tour, self._clusters, self._tour = [], [], []
            return None
        radius_m = book.settings.reevaluate_radius_m
        points = [_points(f, ctx) for f in cands]
        nearest = _nearest_cluster(points)
        pursued = _pursued(book, nearest, radius_m)
        if pursued is not None and not self._event(points, cands[pursued], radius_m):
            return _keep(cands[pursued], book, ctx)
        self.plans += 1
        self._clusters = points
        self._pursued_gain = cands[pursued].gain if pursued is not None else 0
        legs = np.array([self.first_leg(f, ctx) for f in cands])
        # the last tour, as far as its clusters remain, the pursued one first
        old = _matches(self._tour, nearest, radius_m)
        if pursued is not None:
            old = [pursued] + [i for i in old if i != pursued]
        old = old[:max(1, s.tour_max_clusters // 2)]
        cheapest = [int(i) for i in np.argsort(legs, kind="stable")]
        keep = list(dict.fromkeys(old + cheapest))[:s.tour_max_clusters]
        cands, legs, points = [cands[i] for i in keep], legs[keep], [points[i] for i in keep]
        old = list(range(len(old)))               # they lead `keep`
        if not s.use_tour or len(cands) == 1:
            order = [int(i) for i in np.argsort(legs, kind="stable")]
            if old and order[0] != old[0] and not self._switch(legs[old[0]], legs[order[0]], legs[old[0]],
                                                               cands[order[0]], ctx):
                order.remove(old[0])
                order.insert(0, old[0])
        else:
            factor = max(1, int(round(s.tour_cell_m / ctx.resolution)))
            D = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come,
                                          [f.goal_cell for f in cands], ctx.resolution, factor)
            D = _motion(ctx).path_s(D)
            D[0, 1:] = legs
            D = tour.prepare(D)
            fresh = tour.solve(D)
            order = [i - 1 for i in fresh[1:]]
            if old:
                kept = _repair(D, [i + 1 for i in old])
                if kept[1] == fresh[1] or not self._switch(tour.length(D, kept), tour.length(D, fresh),
                                                           legs[old[0]], cands[order[0]], ctx):
                    order = [i - 1 for i in kept[1:]]
        self._tour = [points[i] for i in order]
        self.last_tour = [cands[i].goal for i in order]
        pick = order[0]
        return _keep(cands[pick], book, ctx) if pursued is not None and pick == 0 else cands[pick]

    def _event(self, points: Sequence[np.ndarray], pursued: Frontier, radius_m: float) -> bool:
        """A map event since the last plan: a cluster born or gone, or the pursued cluster's
        gain halved (its view changed)."""
        if not self._clusters or 2 * pursued.gain < self._pursued_gain:
            return True
        return _unmatched(points, self._clusters, radius_m) or _unmatched(self._clusters, points, radius_m)

    @staticmethod
    def _switch(kept_s: float, new_s: float, first_s: float, new_first: Frontier, ctx: Context) -> bool:
        """Leave the tour being followed (whose first leg takes first_s) for a new one: only
        when the new one is faster by more than a switch costs (stopping from the present
        speed, turning to face the new first goal), and not when the first goal is nearer than
        that (arriving costs less than turning away)."""
        motion = _motion(ctx)
        switch_s = motion.stop_s + motion.turn_s(heading_error(ctx, new_first.goal))
        return first_s > switch_s and kept_s - new_s > switch_s


def _matches(tour_points: Sequence[np.ndarray], nearest, radius_m: float) -> List[int]:
    """The clusters of the last tour that remain, in its order: for each, the current cluster
    nearest to most of its cells within radius_m (``nearest``: ``_nearest_cluster`` of the
    current clusters; each current cluster once)."""
    out: List[int] = []
    for old in tour_points:
        counts = nearest(old, radius_m)
        if out:
            counts[out] = 0
        best = int(np.argmax(counts))
        if counts[best] > 0:
            out.append(best)
    return out


def _nearest_cluster(points: Sequence[np.ndarray]):
    """``counts(query, radius_m)``: per cluster of ``points``, how many query points have it as
    their nearest cluster within radius_m (one k-d tree over every cluster's points)."""
    tree = cKDTree(np.concatenate(points))
    owner = np.repeat(np.arange(len(points)), [len(p) for p in points])

    def counts(query: np.ndarray, radius_m: float) -> np.ndarray:
        dist, index = tree.query(query, k=1)
        near = dist <= radius_m + 1e-9
        return np.bincount(owner[index[near]], minlength=len(points))
    return counts


def _repair(D: np.ndarray, old: List[int]) -> List[int]:
    """The last tour brought up to date: its remaining nodes in its order, the first kept; the
    new nodes inserted where they add least, then 2-opt behind the first (``tour.two_opt``)."""
    path = list(old)
    for k in range(1, len(D)):
        if k in path:
            continue
        gaps = [D[path[i], k] + D[k, path[i + 1]] - D[path[i], path[i + 1]] for i in range(len(path) - 1)]
        gaps.append(D[path[-1], k])
        at = int(np.argmin(gaps)) + 1
        path.insert(at, k)
    first = path[0]
    rest = [first] + path[1:]
    sub = D[np.ix_(rest, rest)]
    improved = tour.two_opt(sub, list(range(len(rest))))
    return [0] + [rest[i] for i in improved]


def _motion(ctx: Context):
    if ctx.motion is None:
        raise ValueError("recon costs goals in seconds: the Context needs motion (Motion.of(robot, lattice))")
    return ctx.motion


def _points(f: Frontier, ctx: Context) -> np.ndarray:
    cells = np.reshape(f.cells, (-1, 2)).astype(float)
    return np.column_stack([ctx.origin[0] + (cells[:, 1] + 0.5) * ctx.resolution,
                            ctx.origin[1] + (cells[:, 0] + 0.5) * ctx.resolution])


def _pursued(book: GoalBook, nearest, radius_m: float) -> Optional[int]:
    """The candidate nearest to most of the pursued goal's frontier cells (within radius_m;
    ``nearest``: ``_nearest_cluster`` of the candidates), or None."""
    active = book.active
    if active is None or len(active.frontier_points) == 0:
        return None
    counts = nearest(active.frontier_points, radius_m)
    best = int(np.argmax(counts))
    return best if counts[best] > 0 else None


def _keep(f: Frontier, book: GoalBook, ctx: Context) -> Frontier:
    """The pursued cluster with the goal already sent, where that is still a valid goal (its
    cluster's goal cell moves as the frontier recedes: a new point would replan for nothing)."""
    cell = ctx.xy_to_cell(book.active.goal)
    return with_goal(f, cell, ctx) if ctx.goal_ok(cell) else f


def _unmatched(points: Sequence[np.ndarray], others: Sequence[np.ndarray], radius_m: float) -> bool:
    """Some cluster of ``points`` has no cell within radius_m of any cluster of ``others``."""
    if not others:
        return bool(points)
    tree = cKDTree(np.concatenate(others))
    return any(not np.any(tree.query(p, k=1)[0] <= radius_m + 1e-9) for p in points)
