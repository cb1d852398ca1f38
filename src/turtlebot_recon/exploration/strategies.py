"""Goal selection strategies: one contract, one class and one YAML block each.

A strategy looks at the current frontiers (``frontiers.Frontier``), a ``Context`` (robot
pose, time, grids, seeded RNG) and the shared ``GoalBook``, and returns the frontier to go
to (its ``goal`` / ``goal_cell`` being the point to send), or None when nothing is left.
Strategies never block, hold no clock (``ctx.now_s``) and draw randomness only from
``ctx.rng``. Every returned goal is a cell the robot can stand on (costmap <= ctx.max_cost)
and reach (finite ``ctx.cost_to_come``), and is not blacklisted.

| name                  | source    | rule                                                       |
|-----------------------|-----------|------------------------------------------------------------|
| nearest               | seed 001  | nearest accessible point of the nearest frontier           |
| density               | seed 003  | min (5 dist - frontier neighbours) / attempt weight        |
| gain_distance_heading | seed 004  | max 2.3 unknowns near - 2 dist + 5 cos(heading error)      |
| sampled               | seed 000  | 5 % random frontier cells, nearest or median; tags first   |
| explore_lite          | m-explore | min 3.0 d_min res - 1.0 size res, goal at the centroid     |
| recon (default)       | ours      | first goal of a tour over all clusters on path distances   |

Where a seed sent a point that is not a reachable cell (seed 003's unknown frontier cell,
explore_lite's centroid), the point is snapped to the nearest reachable cell within
``snap_radius_m`` (what the seeds' planners did implicitly: RRT to the nearest tree node,
move_base to the nearest plannable cell); a point with none is skipped. Such goals are
returned as a copy of their frontier with ``goal``, ``goal_cell`` and ``path_cost_m``
replaced (``gain`` stays the cluster's).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Dict, List, Optional, Protocol, Sequence, Tuple

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..config import ConfigError, from_dict, positive, require
from .frontiers import Frontier
from .goals import GoalBook, GoalBookSettings
from . import tour

Point = Tuple[float, float]
Cell = Tuple[int, int]


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

    def xy_to_cell(self, xy: Sequence[float]) -> Cell:
        return (int(math.floor((xy[1] - self.origin[1]) / self.resolution)),
                int(math.floor((xy[0] - self.origin[0]) / self.resolution)))

    def cell_to_xy(self, cell: Sequence[int]) -> Point:
        return (float(self.origin[0] + (cell[1] + 0.5) * self.resolution),
                float(self.origin[1] + (cell[0] + 0.5) * self.resolution))

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
        rows, cols = self.reachable.shape
        return 0 <= r < rows and 0 <= c < cols and bool(self.reachable[r, c])

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


class Strategy(Protocol):
    name: str

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        ...


# ------------------------------------------------------------------------- shared helpers

def reachable_only(frontiers: Sequence[Frontier]) -> List[Frontier]:
    """The clusters the frontier search found a reachable goal for: one behind a gap
    narrower than the robot is never chased, whatever point a strategy would pick in it."""
    return [f for f in frontiers if f.reachable]


def usable(frontiers: Sequence[Frontier], ctx: Context, book: GoalBook) -> List[Frontier]:
    """Frontiers whose own goal is reachable, affordable and not blacklisted."""
    return [f for f in frontiers
            if f.reachable and ctx.goal_ok(f.goal_cell) and not book.is_blacklisted(f.goal)]


def with_goal(frontier: Frontier, cell: Cell, ctx: Context) -> Frontier:
    """``frontier`` with its goal moved to the reachable ``cell``."""
    cell = (int(cell[0]), int(cell[1]))
    return dataclasses.replace(frontier, goal=ctx.cell_to_xy(cell), goal_cell=cell,
                               path_cost_m=float(ctx.cost_to_come[cell]), reachable=True)


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1])


def _heading_error(ctx: Context, xy: Sequence[float]) -> float:
    """|angle| (rad, 0..pi) between the robot's heading and the direction to ``xy``."""
    dx, dy = xy[0] - ctx.robot_xy[0], xy[1] - ctx.robot_xy[1]
    if math.hypot(dx, dy) < 1e-9:
        return 0.0
    err = math.atan2(dy, dx) - ctx.robot_yaw
    return abs(math.atan2(math.sin(err), math.cos(err)))


def _box_count(mask: np.ndarray, k: int) -> np.ndarray:
    """Number of True cells in the (2k + 1)^2 window around every cell (integral image)."""
    rows, cols = mask.shape
    s = np.zeros((rows + 1, cols + 1), dtype=np.int64)
    s[1:, 1:] = mask.astype(np.int64).cumsum(0).cumsum(1)
    r, c = np.arange(rows), np.arange(cols)
    r0, r1 = np.clip(r - k, 0, rows), np.clip(r + k + 1, 0, rows)
    c0, c1 = np.clip(c - k, 0, cols), np.clip(c + k + 1, 0, cols)
    return (s[np.ix_(r1, c1)] - s[np.ix_(r0, c1)] - s[np.ix_(r1, c0)] + s[np.ix_(r0, c0)])


def _window(grid: np.ndarray, cell: Cell, k: int) -> np.ndarray:
    r, c = cell
    return grid[max(r - k, 0):r + k + 1, max(c - k, 0):c + k + 1]


# ----------------------------------------------------------------------- nearest (seed 001)

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
            key = (_distance(ctx.robot_xy, ctx.cell_to_xy(cell)),
                   _distance(ctx.robot_xy, f.closest), f.id)
            if best_key is None or key < best_key:
                best, best_key = (f, cell), key
        return None if best is None else with_goal(best[0], best[1], ctx)


# ----------------------------------------------------------------------- density (seed 003)

@dataclass(frozen=True)
class DensitySettings:
    distance_weight_per_m: float = 5.0   # HEUR_DISTANCE_WEIGHT: 5 per metre vs 5..50 neighbours
    frontier_radius_cells: int = 8       # FRONTIER_RADIUS: neighbourhood half-width (cells)
    clear_neighbours_min: int = 5        # CLEAR_NEIGHBOR_FRONTIER_THRESH: need more clear cells
    free_threshold: int = 25             # occupancy <= this is clear
    occupied_threshold: int = 65         # occupancy >= this is blocked; between: unexplored
    weight_decrement: float = 0.2        # FRONTIER_WEIGHT_DECREMENT per failure nearby
    weight_min: float = 0.01             # the weight's floor (no division by 0)
    weight_radius_m: float = 0.4         # failures this close lower a cell's weight (8 cells)
    snap_radius_m: float = 0.6           # seed 003's cells lie up to 8 cells inside unknown
    max_candidates: int = 500            # cheapest cells tried for a reachable goal

    def validate(self, src: str) -> None:
        positive(src, self, "frontier_radius_cells", "weight_decrement", "weight_min",
                 "weight_radius_m", "snap_radius_m", "max_candidates")
        require(0 <= self.free_threshold < self.occupied_threshold <= 100, src, "free_threshold",
                "need 0 <= free_threshold < occupied_threshold <= 100")
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
        clear = (occ >= 0) & (occ <= s.free_threshold)
        blocked = occ >= s.occupied_threshold
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
        xy = np.stack([ctx.origin[0] + (cells[:, 1] + 0.5) * ctx.resolution,
                       ctx.origin[1] + (cells[:, 0] + 0.5) * ctx.resolution], axis=1)
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


# -------------------------------------------------------- gain_distance_heading (seed 004)

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
        window = _window(ctx.occupancy, f.goal_cell, s.value_radius_cells)
        unknowns = int(np.count_nonzero(window < 0))
        return (s.unknown_weight * unknowns
                + s.distance_weight_per_m * _distance(ctx.robot_xy, f.goal)
                + s.heading_weight * math.cos(_heading_error(ctx, f.goal)))

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        cands = usable(frontiers, ctx, book)
        if self.settings.top_clusters > 0:
            cands = sorted(cands, key=lambda f: -f.size)[:self.settings.top_clusters]
        if not cands:
            return None
        scores = [self.score(f, ctx) for f in cands]
        return cands[int(np.argmax(scores))]


# ----------------------------------------------------------------------- sampled (seed 000)

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
        dist = np.array([_distance(ctx.robot_xy, p) for p in xy])
        key = dist if s.selection == "nearest" else np.abs(dist - np.median(dist))
        for j in np.argsort(key, kind="stable"):
            goal = ctx.snap(xy[j], s.snap_radius_m)
            if goal is not None and not book.is_blacklisted(ctx.cell_to_xy(goal)):
                return with_goal(frontiers[int(owner[picked[j]])], goal, ctx)
        return None

    def _priority(self, ctx: Context, book: GoalBook) -> Optional[Frontier]:
        for p in sorted(ctx.priority_goals, key=lambda p: _distance(ctx.robot_xy, p)):
            goal = ctx.snap(p, self.settings.snap_radius_m)
            if goal is None or book.is_blacklisted(ctx.cell_to_xy(goal)):
                continue
            xy = ctx.cell_to_xy(goal)
            return Frontier(id=-1, cells=np.zeros((0, 2), dtype=np.int32), size=0, length_m=0.0,
                            centroid=(float(p[0]), float(p[1])), closest=(float(p[0]), float(p[1])),
                            goal=xy, goal_cell=goal, gain=0,
                            path_cost_m=float(ctx.cost_to_come[goal]), reachable=True)
        return None


# ----------------------------------------------------------------- explore_lite (m-explore)

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
        min_distance = _distance(ctx.robot_xy, f.closest)
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
            min_distance = _distance(ctx.robot_xy, f.closest)
            same_goal = (self._prev_goal is not None
                         and _distance(self._prev_goal, f.centroid) < 1e-9)
            self._prev_goal = f.centroid
            if not same_goal or self._prev_distance_m > min_distance:
                self._last_progress_s, self._prev_distance_m = ctx.now_s, min_distance
            if ctx.now_s - self._last_progress_s > s.progress_timeout_s:
                book.blacklist(f.centroid, ctx.now_s)
                continue
            return with_goal(f, cell, ctx)


# ------------------------------------------------------------------------------ recon (ours)

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
    min_gain_m2: float = 0.1               # smaller gains only when nothing larger is left
    max_arrivals: int = 2                  # goals reached this often nearby are not chosen again
    use_tour: bool = True                  # order all clusters as a tour (false: least first leg)
    tour_max_clusters: int = 20            # the cheapest first legs enter the tour (n Dijkstras)
    hysteresis_m: float = 1.0              # keep the last goal unless the new tour is this much
    hysteresis_ratio: float = 0.1          # ... or this fraction shorter (the larger of the two)
    match_radius_m: float = 0.5            # the last goal "is still there" within this radius

    def validate(self, src: str) -> None:
        for key in ("turn_weight_m_per_rad", "gain_weight_m_per_m2", "visit_weight_m_per_visit",
                    "min_gain_m2", "hysteresis_m", "hysteresis_ratio"):
            require(getattr(self, key) >= 0, src, key, "must be >= 0")
        positive(src, self, "visit_radius_m", "match_radius_m")
        require(isinstance(self.max_arrivals, int) and self.max_arrivals >= 1, src,
                "max_arrivals", "must be an integer >= 1")
        require(isinstance(self.tour_max_clusters, int) and self.tour_max_clusters >= 1, src,
                "tour_max_clusters", "must be an integer >= 1")


class Recon:
    """Ours: the first goal of a short tour through every reachable cluster.

    First leg (robot -> goal i), in metres of path:
        leg_i = path_cost_i + turn_weight * |heading error_i|
                + visit_weight * visits_i - gain_weight * gain_area_i
    path_cost from the Dijkstra field (not Euclidean: walls count); heading error to the
    goal's straight-line bearing; visits = most passes recorded within visit_radius_m of the
    goal; gain_area = gain cells * resolution^2. Between goals: Dijkstra path distances
    (``tour.path_distance_matrix``). The clusters are ordered by nearest insertion + 2-opt
    from the robot (``tour.solve``) and the first is chosen, so the robot finishes one end
    of the building before crossing to the other. Hysteresis: the last goal is kept while
    the best tour that starts with it is at most max(hysteresis_m, hysteresis_ratio *
    |best|) longer than the best tour.

    Candidates: usable goals (reachable, affordable, not blacklisted) not yet reached
    max_arrivals times (a frontier that survived the visits cannot be cleared from there);
    gains below min_gain_m2 only when nothing richer is left; the tour_max_clusters
    cheapest first legs enter the tour.
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
            window = _window(ctx.visits, f.goal_cell, k)
            visits = int(window.max()) if window.size else 0
        return (f.path_cost_m + s.turn_weight_m_per_rad * _heading_error(ctx, f.goal)
                + s.visit_weight_m_per_visit * visits
                - s.gain_weight_m_per_m2 * f.gain * ctx.resolution ** 2)

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        s = self.settings
        cands = [f for f in usable(frontiers, ctx, book) if book.successes(f.goal) < s.max_arrivals]
        rich = [f for f in cands if f.gain * ctx.resolution ** 2 >= s.min_gain_m2]
        cands = rich or cands
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
            D = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come,
                                          [f.goal_cell for f in cands], ctx.resolution)
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
        dist = [_distance(self.last_goal, f.goal) for f in cands]
        last = int(np.argmin(dist))
        if dist[last] > s.match_radius_m or last == pick:
            return pick
        node = last + 1                    # forced first: solve the rest from there
        rest = [node] + [i for i in range(1, len(D)) if i != node]
        sub = D[np.ix_(rest, rest)]
        forced_m = D[0, node] + tour.length(sub, tour.solve(sub))
        margin = max(s.hysteresis_m, s.hysteresis_ratio * abs(best_m))
        return last if forced_m <= best_m + margin else pick


# ------------------------------------------------------------------ registry and configuration

STRATEGIES: Dict[str, type] = {cls.name: cls for cls in
                               (Nearest, Density, GainDistanceHeading, Sampled, ExploreLite, Recon)}
DEFAULT_STRATEGY = "recon"


def make_strategy(name: str, params: Optional[dict] = None, source: str = "explorer") -> Strategy:
    """Strategy ``name`` with ``params`` (its YAML block); ConfigError names any bad key."""
    if name not in STRATEGIES:
        raise ConfigError(f"{source}/strategy: unknown strategy {name!r}; "
                          f"known: {sorted(STRATEGIES)}")
    cls = STRATEGIES[name]
    if params is not None and not isinstance(params, dict):
        raise ConfigError(f"{source}/strategies/{name}: expected a mapping, got {params!r}")
    return cls(from_dict(cls.Settings, params or {}, f"{source}/strategies/{name}"))


def load_strategy(config: dict, source: str = "explorer") -> Tuple[Strategy, GoalBookSettings]:
    """The strategy named by ``config['strategy']`` (default recon) with its block from
    ``config['strategies']``, and the GoalBook settings from ``config['goals']``. Every
    strategy block is validated, not only the chosen one, so a typo anywhere fails loudly."""
    blocks = config.get("strategies") or {}
    if not isinstance(blocks, dict):
        raise ConfigError(f"{source}/strategies: expected a mapping, got {blocks!r}")
    unknown = sorted(set(blocks) - set(STRATEGIES))
    if unknown:
        raise ConfigError(f"{source}/strategies: unknown strategy block(s) {unknown}; known: "
                          f"{sorted(STRATEGIES)}")
    built = {name: make_strategy(name, block, source) for name, block in blocks.items()}
    name = config.get("strategy", DEFAULT_STRATEGY)
    strategy = built.get(name) or make_strategy(name, None, source)
    goals = from_dict(GoalBookSettings, config.get("goals") or {}, f"{source}/goals")
    return strategy, goals
