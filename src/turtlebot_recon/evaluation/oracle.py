"""An omniscient reference route for exploration (simulation only: it reads the true map).

How short could exploration be if the robot knew the building? ``Oracle.route`` plans, on
the world itself, a route from the start whose lidar sees ``target`` of F (DESIGN §6), and
``scripts/oracle_driver`` drives it through the same navigator as every strategy. Its time to
99 % is then what goal selection alone can reach with this navigator, follower and initial
spin: the headroom left to any strategy, and a check on targets stated as ratios between them.

The route is a heuristic (no optimum is claimed; watchman routes are NP-hard):

1. viewpoints   one cell per ``lattice_m`` block of the cells the navigator's state lattice
                reaches from the start on the true map with the robot's footprint
                (``coverage.reachable_cells``: F's and the explorer's reachability) with cost
                <= ``max_cost`` (its goal rule), and F's own viewpoints where those miss an F
                cell (``Oracle._viewpoints``): every F cell is seen from a candidate;
2. sight        the F cells each sees: line of sight within the model's range, LIDAR_BEAMS
                rays (``_native.visible_cells``, as F itself is made); a cell that no candidate
                sees so near counts at the lidar's full range (F's), so the target is always
                within reach: a route is finite wherever F is;
3. cover        greedy set cover, from what the start sees, until ``target`` of F; restarts
                draw each choice among the 3 largest gains (seeded);
4. order        an open tour from the start on path distances (``tour.solve``, the way back free);
5. model drive  A* between consecutive points, seeing every ``sample_m`` of path: the distance at
                which ``target`` is seen; viewpoints whose removal does not lengthen it are
                dropped (then the tour is solved again), the shortest restart kept.

The robot's map marks a cell free after about three misses, so a cell seen once near the
range limit may stay unknown: the model sees ``range_margin_m`` less far than the lidar (a
route planned with the full range ended at 98.4-98.9 % in the house and the maze; the driver
re-plans for what is left, at a cost in time).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .. import _native
from ..config import positive, require
from ..exploration import tour
from ..geometry import cells_to_points
from ..planning.costmap import PlannerSettings, cost_model
from ..planning.lattice import LatticeSettings, footprint_costmap
from ..robot import RobotSpec
from ..sim.world import World
from .coverage import LATTICE_M, LIDAR_BEAMS, free_at, lattice_points, reachable_cells, visible_free_space

_TOP_K = 3          # a restart's greedy step draws among this many largest gains
_SNAP_CELLS = 4     # a position in the inscribed band counts as the nearest passable cell this close


@dataclass(frozen=True)
class OracleSettings:
    target: float = 0.99           # share of F the model route must see
    range_margin_m: float = 0.5    # m, the model sees this much less far than the sensor (below)
    lattice_m: float = 0.5         # m, viewpoint spacing
    max_cost: int = 128            # a viewpoint's cost must be <= this (frontiers.max_cost's rule)
    sample_m: float = 0.1          # m, the model sees every this much of path
    restarts: int = 3              # randomised covers tried after the plain greedy one
    seed: int = 0                  # their RNG

    def validate(self, src: str) -> None:
        positive(src, self, "target", "lattice_m", "sample_m")
        require(self.range_margin_m >= 0, src, "range_margin_m", "must be >= 0")
        require(self.target <= 1.0, src, "target", "must be in (0, 1]")
        require(isinstance(self.max_cost, int) and 0 <= self.max_cost <= 252, src, "max_cost",
                "must be an integer in 0..252")
        require(isinstance(self.restarts, int) and self.restarts >= 0, src, "restarts",
                "must be an integer >= 0")


@dataclass(frozen=True)
class OracleDriverSettings:
    """config/oracle.yaml: scripts/oracle_driver, which drives the oracle's routes."""
    world: str = ""                  # a name in worlds/ or a world YAML; no default: the launch
                                         # files set it (their top-level files hold its one default)
    robot: str = ""                  # costmap footprint, F's radius and lidar range; no default: the launch
                                         # files set it (their top-level files hold its one default)
    map_frame: str = "odom"              # goals go out in this frame (the start pose is its origin)
    route: OracleSettings = field(default_factory=OracleSettings)
    lattice: LatticeSettings = field(default_factory=LatticeSettings)   # config/lattice.yaml
    replan_restarts: int = 0             # randomised covers for the routes after the first
    finish_coverage: float = 0.995       # share of F the robot's map covers: done
    resend_period_s: float = 1.0         # s (sim), the map is checked for a nearer point this often
    advance_m: float = 0.5               # m, ... which replaces the one driven to once this much further
    point_timeout_s: float = 120.0       # s (sim), a route point not reached by then is skipped
    max_routes: int = 5                  # routes planned in all (the first and the re-plans)
    min_route_gain: float = 0.0005       # a re-planned route that adds less of F than this: done
    start_timeout_wall_s: float = 60.0   # s (wall), for move_base, /clock, /map and the ground truth at
                                         # the start; then the node exits 1 naming what is missing

    def validate(self, src: str) -> None:
        positive(src, self, "finish_coverage", "resend_period_s", "advance_m", "point_timeout_s", "max_routes",
                 "min_route_gain", "start_timeout_wall_s")
        require(self.finish_coverage <= 1.0, src, "finish_coverage", "must be in (0, 1]")
        require(isinstance(self.replan_restarts, int) and self.replan_restarts >= 0, src,
                "replan_restarts", "must be an integer >= 0")


@dataclass(frozen=True)
class Route:
    points: np.ndarray      # float (n, 2), world frame (m), in driving order (the start excluded)
    distance_m: float       # model distance from the start until ``seen`` of F is seen
    seen: float             # share of F the model route sees in all
    viewpoints: int         # candidates considered


class Oracle:
    """The true costmap, F, what each viewpoint sees (cached across routes), and routes."""

    def __init__(self, world: World, robot: RobotSpec, sensor_range_m: float,
                 settings: OracleSettings = OracleSettings(),
                 lattice: LatticeSettings = LatticeSettings()):
        settings.validate("oracle")
        self.world, self.s, self.res = world, settings, world.resolution
        self._cost = cost_model(PlannerSettings(), self.res)       # the planner's step cost
        self.solid = world.solid.astype(np.uint8)
        self.full_radius_cells = sensor_range_m / self.res
        self.radius_cells = max(0.0, sensor_range_m - settings.range_margin_m) / self.res
        # the navigator's graded costmap (253 where no heading of the footprint fits) for path
        # distances, and its lattice for where the robot can go: F's reachability
        lattice = lattice.with_robot(robot)
        self.costmap = footprint_costmap(world.occupancy(), self.res, robot, lattice)
        if self.cell(world.start[0], world.start[1]) is None:
            raise ValueError(f"{world.path}: the start is off the map or in an obstacle's "
                             "inscribed band")
        reach = reachable_cells(world, robot, lattice)
        self.F = visible_free_space(world, reach, sensor_range_m).ravel()
        self.F_cells = np.flatnonzero(self.F)      # CoverageTracker's order (row-major)
        self._sight: dict = {}
        self._legs: dict = {}
        self._pairs: dict = {}              # (cell, cell) -> path distance (m)
        self.need = 0                       # F cells the route being planned must see
        self.cells = self._viewpoints(reach)

    def _viewpoints(self, reach: np.ndarray) -> np.ndarray:
        """Candidate viewpoints (int32 (n, 2)) such that every F cell is seen from one.

        One per ``lattice_m`` block of the reachable cells with cost <= ``max_cost``; where
        those miss F cells (seen only from a gap's inside, whose cost is higher, or from
        between the blocks' picks), F's own viewpoints that see them are added. A cell that no
        candidate sees within the model's shortened range is counted at the full range
        (``sight``): F is what the lidar sees, so a route over these candidates always reaches
        the target (a hall seen only through gaps, from 3-3.5 m, made the route infinite)."""
        ok = reach & (self.costmap <= self.s.max_cost)
        cells = lattice_points(ok, max(1, round(self.s.lattice_m / self.res)))
        seen, near = np.zeros(self.F.size, bool), np.zeros(self.F.size, bool)
        for c in cells:
            seen[self._seen_from(c, self.full_radius_cells)] = True
            near[self._seen_from(c, self.radius_cells)] = True
        missed = self.F & ~seen
        if missed.any():
            # only F's viewpoints within the lidar's range of a missed cell can see one
            reach_missed = ndimage.distance_transform_edt(~missed.reshape(reach.shape)) <= self.full_radius_cells
            extra = []
            for c in lattice_points(reach, max(1, int(round(LATTICE_M / self.res)))):
                if not reach_missed[c[0], c[1]]:
                    continue
                full = self._seen_from(c, self.full_radius_cells)
                if not seen[full].all():
                    extra.append(c)
                    seen[full] = True
                    near[self._seen_from(c, self.radius_cells)] = True
            cells = np.concatenate([cells, np.reshape(extra, (-1, 2))]).astype(np.int32)
        self._far_only = self.F & ~near     # F cells no candidate sees within the model's range
        return cells

    def cell(self, x: float, y: float):
        """The world cell (row, col) of (x, y), or the nearest passable one within
        ``_SNAP_CELLS`` (a robot grazing the inscribed band); None if there is none."""
        r, c = self.world.cell(x, y)
        rows, cols = self.costmap.shape
        # clipped to the grid at both ends: a negative end would index from the far side
        r0, r1 = max(0, r - _SNAP_CELLS), max(0, min(rows, r + _SNAP_CELLS + 1))
        c0, c1 = max(0, c - _SNAP_CELLS), max(0, min(cols, c + _SNAP_CELLS + 1))
        rr, cc = np.nonzero(self.costmap[r0:r1, c0:c1] < 253)
        if rr.size == 0:
            return None
        k = int(np.argmin((rr + r0 - r) ** 2 + (cc + c0 - c) ** 2))
        return int(rr[k] + r0), int(cc[k] + c0)

    def path(self, start_xy, goal_xy) -> np.ndarray:
        """The cheapest path on the true costmap (world frame, float (n, 2)); (0, 2) if none."""
        a, b = self.cell(*start_xy), self.cell(*goal_xy)
        if a is None or b is None:
            return np.zeros((0, 2))
        cells, _ = _native.astar(self.costmap, a, b, **self._cost)
        return self._xy(cells)

    def _xy(self, cells) -> np.ndarray:
        return cells_to_points(np.reshape(cells, (-1, 2)), self.res, self.world.origin)

    def _seen_from(self, cell, radius_cells: float) -> np.ndarray:
        """Flat indices (int32) of the F cells seen from ``cell`` (row, col) within
        ``radius_cells``: line of sight, LIDAR_BEAMS rays."""
        seen = _native.visible_cells(self.solid, np.array([[int(cell[0]), int(cell[1])]], np.int32),
                                     radius_cells, beams=LIDAR_BEAMS).ravel()
        return np.flatnonzero(seen & self.F).astype(np.int32)

    def sight(self, cell) -> np.ndarray:
        """Flat indices (int32) of the F cells the model sees from ``cell`` (row, col): those
        within the model's range, and those no candidate sees so near within the full range.
        Cached (int32 halves what a big floor's thousands of viewpoints hold)."""
        key = (int(cell[0]), int(cell[1]))
        if key not in self._sight:
            v = self._seen_from(key, self.radius_cells)
            if self._far_only.any():
                full = self._seen_from(key, self.full_radius_cells)
                v = np.union1d(v, full[self._far_only[full]])
            self._sight[key] = v
        return self._sight[key]

    def route(self, start_xy=None, covered=None, restarts=None, target=None) -> Route:
        """The shortest model route, from ``start_xy`` (world, m; default the world's start)
        with the F cells ``covered`` (bool, CoverageTracker's order; default none) already
        seen, until ``target`` of F (default: the settings'): the plain greedy cover and
        ``restarts`` (default: the settings') randomised ones (module docstring).
        distance_m is inf if no route reaches the target (more than the viewpoints see)."""
        self.need = math.ceil((self.s.target if target is None else target) * self.F_cells.size)
        xy = self.world.start[:2] if start_xy is None else start_xy
        start = self.cell(*xy)
        if start is None:
            raise ValueError(f"the route's start ({xy[0]:.2f}, {xy[1]:.2f}) is off the map or "
                             "in an obstacle's inscribed band")
        known = np.zeros(self.F.size, bool)
        if covered is not None:
            known[self.F_cells[np.asarray(covered, bool)]] = True
        rng = np.random.default_rng(self.s.seed)
        best = None
        for attempt in range((self.s.restarts if restarts is None else restarts) + 1):
            chosen = self._cover(start, known, None if attempt == 0 else rng)
            chosen, d = self._prune(start, known, self._order(start, chosen))
            if best is None or d < best[1]:
                best = (chosen, d)
        chosen, d = best
        points = self._xy(self.cells[chosen])
        _, seen = self._drive(start, known, chosen)
        return Route(points=points, distance_m=d, seen=seen, viewpoints=len(self.cells))

    # ------------------------------------------------------------------ the steps
    def _cover(self, start, known, rng) -> list:
        """Greedy set cover (candidate indices); with ``rng``, each step draws among the
        ``_TOP_K`` largest gains. Lazy: a gain only shrinks as cells get covered, so a stale
        one is an upper bound, and only candidates whose bound could win are re-counted."""
        covered = known.copy()
        covered[self.sight(start)] = True
        sights = [self.sight(c) for c in self.cells]
        bound = np.array([np.count_nonzero(~covered[v]) for v in sights], float)
        k = 1 if rng is None else _TOP_K
        count, chosen = int(np.count_nonzero(covered)), []
        while count < self.need and bound.size:
            work, best = bound.copy(), {}
            while len(best) < k:
                i = int(np.argmax(work))
                if work[i] <= 0:
                    break
                g = np.count_nonzero(~covered[sights[i]])
                bound[i], work[i] = g, -np.inf
                if g >= work.max():
                    best[i] = g                     # no stale bound can beat it: confirmed
                else:
                    work[i] = g                     # re-queued with its true gain
            if not best:
                break
            i = max(best, key=best.get) if rng is None else int(rng.choice(sorted(best)))
            chosen.append(i)
            count += best[i]
            covered[sights[i]] = True
            bound[i] = 0.0
        return chosen

    def _order(self, start, chosen: list) -> list:
        """``chosen`` as an open tour from ``start`` on path distances."""
        cells = [start] + [(int(self.cells[i][0]), int(self.cells[i][1])) for i in chosen]
        for a in cells:                     # one Dijkstra per cell that lacks a pair, cached
            if any((a, b) not in self._pairs for b in cells):
                field = _native.dijkstra(self.costmap, a, **self._cost, targets=np.array(cells, np.int32))
                self._pairs.update({(a, b): float(field[b]) for b in cells})
        D = np.array([[self._pairs[(a, b)] for b in cells] for a in cells])
        D = np.minimum(D, D.T)
        D[~np.isfinite(D)] = tour.UNREACHABLE_M
        D[:, 0] = 0.0                       # the way back to the start is free: an open route
        return [chosen[k - 1] for k in tour.solve(D) if k != 0]

    def _leg(self, a, b) -> tuple:
        """The model drive a -> b (cells), cached: (length m, arc length of each sample,
        the F cells each sample sees, the union of those)."""
        key = (a, b)
        if key not in self._legs:
            path, _ = _native.astar(self.costmap, a, b, **self._cost)
            if len(path) < 2:
                self._legs[key] = (0.0, np.zeros(0), [], np.zeros(0, np.int64))
            else:
                step = np.hypot(*np.diff(path, axis=0).T) * self.res
                s = np.concatenate([[0.0], np.cumsum(step)])
                marks = np.arange(self.s.sample_m, s[-1] + 1e-9, self.s.sample_m)
                idx = np.unique(np.append(np.minimum(np.searchsorted(s, marks), len(path) - 1),
                                          len(path) - 1))
                sights = [self.sight(path[j]) for j in idx]
                seen = np.zeros(self.F.size, bool)
                for v in sights:
                    seen[v] = True
                self._legs[key] = (float(s[-1]), s[idx], sights, np.flatnonzero(seen))
        return self._legs[key]

    def _drive(self, start, known, chosen: list) -> tuple:
        """(distance (m) at which ``need`` F cells are seen, or inf; share of F seen in all).
        Leg by leg on the legs' unions; sample by sample only in the leg that crosses ``need``."""
        covered = known.copy()
        covered[self.sight(start)] = True
        count, done_m, cur = int(np.count_nonzero(covered)), 0.0, start
        hit = 0.0 if count >= self.need else math.inf
        for i in chosen:
            goal = (int(self.cells[i][0]), int(self.cells[i][1]))
            length, s, sights, union = self._leg(cur, goal)
            new = union[~covered[union]]
            if math.isinf(hit) and count + new.size >= self.need:
                for sj, v in zip(s, sights):
                    count += int(np.count_nonzero(~covered[v]))
                    covered[v] = True
                    if count >= self.need:
                        hit = done_m + float(sj)
                        break
                new = union[~covered[union]]
            covered[new] = True
            count += new.size
            done_m += length
            cur = goal
        return hit, count / max(1, self.F_cells.size)

    def _prune(self, start, known, chosen: list) -> tuple:
        """Drop viewpoints whose removal does not lengthen the drive; (chosen, distance)."""
        best, _ = self._drive(start, known, chosen)
        dropped = math.isfinite(best)      # nothing to keep while the target is not reached
        while dropped:
            dropped = False
            for k in range(len(chosen) - 1, -1, -1):
                trial = chosen[:k] + chosen[k + 1:]
                d, _ = self._drive(start, known, trial)
                if d <= best + 1e-9:
                    chosen, best, dropped = trial, d, True
            if dropped:
                again = self._order(start, chosen)
                d, _ = self._drive(start, known, again)
                if d < best:
                    chosen, best = again, d
        return chosen, best


def farthest_known_free(points: np.ndarray, occupancy: np.ndarray, resolution: float,
                        origin_xy: tuple):
    """The index of the last of ``points`` (float (n, 2), map frame) up to which every point
    lies on a cell the map (int8 ROS values, row 0 at ``origin_xy``) marks free; None if the
    first does not. A goal there can be planned to through known space."""
    pts = np.asarray(points, float).reshape(-1, 2)
    free = free_at(pts[:, 0], pts[:, 1], occupancy, resolution, origin_xy)
    if not free.size or not free[0]:
        return None
    gaps = np.flatnonzero(~free)
    return int(gaps[0] - 1) if gaps.size else len(pts) - 1
