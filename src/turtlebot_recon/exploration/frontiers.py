"""Frontier detection, clustering and goal points (seeds 004 and 001), with information gain.

A frontier cell is an UNKNOWN cell with at least one free cell among its 8 neighbours:
seed 004 convolves the free mask with a 3x3 kernel of ones and ANDs the result with the
unknown mask. (Yamauchi's and seed 001's "frontier edge" is the free cell on the other
side; marking the unknown side keeps every frontier cell inside the space still to be
seen.) Frontier cells are grouped into 8-connected clusters (seed 004's BFS, here
scipy.ndimage.label) and clusters smaller than ``min_size_cells`` are noise.

Each cluster gets one goal. Its representative point is the cluster's cell nearest its
centroid (the mean of a curved frontier may lie off it), optionally pushed up to
``extend_into_unknown_m`` further from the robot while it stays in unknown space (seed 004's
point extension, for corridors), then snapped to the nearest cell that the robot can stand
on (cost <= ``max_cost``, seed 001's "nearest accessible point") AND reach (a finite
cost-to-come in the robot's Dijkstra field), searching outward past accessible cells that
are not connected to the robot. "Nearest" is measured along a path of such cells (or
unknown ones) within ``snap_radius_m``, not in a straight line, so that a snap never jumps a
wall: a frontier behind a gap narrower than the robot finds no reachable cell on its side.
With the default field (unknown space forbidden) an extended point snaps back to the known
side of the frontier; the extension moves the goal itself only for a caller whose field
crosses unknown space (a planner with unknown_cost >= 0, as Nav2's allow_unknown in seed
004).

A goal is a viewpoint: a cell the robot stands on and reaches, from which it looks at the
frontier. Where the snap's cell lies within a tried disc (near a goal reached before), and,
once no frontier is left that the snap finds a goal for, where the snap finds none, the goal
is the nearest cell that sees a frontier cell the reached goals did not, by line of sight
over known-free cells within ``sensor_range_m`` (``viewpoints``): a frontier that an arrival
did not reveal (clutter hid it) gets another viewpoint, and one seen through a gap narrower
than the robot gets a goal in front of the gap. Looking through gaps comes last because
driving to the frontiers beside reachable space grows that space, and the passes on the way
show much of what lies behind the gaps (chased in tour order, the gaps cost recon about
20 % more driving in the house and the arena). A frontier without a goal comes back with
``reachable=False`` (not dropped, so that callers can report it); when no frontier has a
goal, none is seen from anywhere the robot reaches: nothing is left to see. Gain is the
number of unknown cells a lidar at the goal cell would see (C++ ray casting,
``_native.visible_unknown``).

Grids are nav_msgs/OccupancyGrid order: ``(rows, cols)``, row 0 at the smallest y; int8
occupancy -1 unknown, 0..100; cell (r, c) has its centre at origin + ((c + 0.5) res,
(r + 0.5) res) in the map frame (the map's origin is assumed unrotated).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from .. import _native
from ..config import positive, require
from ..geometry import cell_to_xy, inside
from ..mapping.map_io import FREE_THRESH
from ..planning import (FREE_SPACE, INSCRIBED, LETHAL, NO_INFORMATION, dijkstra,
                        nearest_accessible)
from .viewpoints import Tried, Viewpoints

Cell = Tuple[int, int]
Point = Tuple[float, float]

# The 8 neighbours of a cell (the centre is unknown wherever the result is used).
_NEIGHBOURS = np.ones((3, 3), dtype=np.uint8)
_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class FrontierSettings:
    min_size_cells: int = 3             # smaller clusters are noise (seed 004)
    min_opening_cells: int = 3          # a frontier borders free cells that lie in a free square
                                        # this many cells across (find_frontier_cells); 1: any
    sensor_range_m: float = 3.5         # gain counts unknown cells within this range (LDS-01)
    gain_beams: int = 180               # rays cast per goal for the gain
    extend_into_unknown_m: float = 0.0  # push the representative point this far from the robot
                                        # into unknown space before snapping (seed 004); 0: off
    snap_radius_m: float = 1.0          # search radius (path length) for the goal cell
    max_cost: int = 128                 # a goal cell's cost should be <= this (128: 0.135 m beyond
                                        # the inscribed band); if no such cell is near, any cell
                                        # below inscribed
    look_range_m: float = 2.5           # an unknown cell looked at within this range ...
    look_spacing_m: float = 0.25        # ... from this many places this far apart ...
    looks_to_spend: int = 2             # ... is no frontier (viewpoints.Looks); 0: off

    def validate(self, src: str) -> None:
        for key in ("min_size_cells", "min_opening_cells"):
            require(isinstance(getattr(self, key), int) and getattr(self, key) >= 1, src, key,
                    "must be an integer >= 1")
        positive(src, self, "sensor_range_m", "snap_radius_m", "look_range_m", "look_spacing_m")
        require(isinstance(self.looks_to_spend, int) and self.looks_to_spend >= 0, src,
                "looks_to_spend", "must be an integer >= 0 (0 turns the rule off)")
        require(isinstance(self.gain_beams, int) and self.gain_beams >= 1, src, "gain_beams",
                "must be an integer >= 1")
        require(math.isfinite(self.extend_into_unknown_m) and self.extend_into_unknown_m >= 0,
                src, "extend_into_unknown_m", "must be >= 0 (0 turns the extension off)")
        require(isinstance(self.max_cost, int) and 0 <= self.max_cost < INSCRIBED, src,
                "max_cost", f"must be an integer in 0..{INSCRIBED - 1} (below inscribed)")


@dataclass(frozen=True, eq=False, repr=False)
class Frontier:
    """One cluster of frontier cells and its goal. Positions are metres in the map frame."""
    id: int                  # index in this detection, 0..n-1 (clusters in raster order)
    cells: np.ndarray        # int32 (n, 2) (row, col) frontier cells (read-only)
    size: int                # number of cells
    length_m: float          # size * resolution (explore_lite's frontier "size")
    centroid: Point          # (x, y) m, mean of the cells' centres
    closest: Point           # (x, y) m of the frontier cell nearest (Euclidean) to the robot
    goal: Point              # (x, y) m of goal_cell's centre
    goal_cell: Cell          # (row, col): the reachable cell nearest the representative point,
                             # or a viewpoint (module docstring); without a goal: the snap's
                             # cell (the nearest one the robot could stand on, else the
                             # representative cell itself)
    gain: int                # unknown cells visible from goal_cell within sensor_range_m
    path_cost_m: float       # cost-to-come from the robot to goal_cell; inf if unreachable
    reachable: bool          # it has a goal (path_cost_m finite); False: given up, or seen
                             # only through a gap while another frontier has a snapped goal

    def __repr__(self) -> str:
        return (f"Frontier(id={self.id}, size={self.size}, centroid=({self.centroid[0]:.2f}, "
                f"{self.centroid[1]:.2f}), goal=({self.goal[0]:.2f}, {self.goal[1]:.2f}), "
                f"gain={self.gain}, path_cost_m={self.path_cost_m:.2f}, "
                f"reachable={self.reachable})")


def find_frontier_cells(occupancy: np.ndarray, free_threshold: int = FREE_THRESH,
                        opening_cells: int = 1) -> np.ndarray:
    """Bool mask of the UNKNOWN cells (< 0) with at least one free (0..free_threshold) cell
    among their 8 neighbours (seed 004: convolve(free, 3x3 ones) > 0, AND unknown; its table
    says "> 1 free neighbour", but a single free neighbour already borders the unknown, and
    requiring two would miss the tip of a one-cell-wide free strip). Cells beyond the grid's
    edge count as not free.

    opening_cells > 1: only free cells that lie in an all-free square of that many cells
    across count (the free mask's morphological opening): a slit narrower than that in a
    wall line (a cell of the wall's face that grazing rays cleared) or a stray free cell
    shows nothing of what lies behind it, while a doorway or a slit the lidar looks through
    keeps its frontier. 1: seed 004's rule."""
    occupancy = np.asarray(occupancy)
    if occupancy.ndim != 2:
        raise ValueError(f"find_frontier_cells: occupancy must be 2-D, got {occupancy.ndim}-D")
    free = (occupancy >= 0) & (occupancy <= free_threshold)
    if opening_cells > 1:
        free = ndimage.binary_opening(free, structure=np.ones((opening_cells,) * 2, dtype=bool))
    free_neighbours = ndimage.convolve(free.astype(np.uint8), _NEIGHBOURS, mode="constant", cval=0)
    return (occupancy < 0) & (free_neighbours > 0)


def cluster(mask: np.ndarray, min_size: int = 1) -> List[np.ndarray]:
    """8-connected components of a bool mask with at least ``min_size`` cells, each an int32
    (n, 2) array of (row, col) in raster order; components in raster order of their first
    cell."""
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim != 2:
        raise ValueError(f"cluster: mask must be 2-D, got {mask.ndim}-D")
    labels, count = ndimage.label(mask, structure=_EIGHT_CONNECTED)
    if count == 0:
        return []
    flat = labels.ravel()
    index = np.flatnonzero(flat)
    index = index[np.argsort(flat[index], kind="stable")]  # by label, raster order inside
    sizes = np.bincount(flat[index], minlength=count + 1)[1:]
    rows, cols = np.divmod(index, mask.shape[1])
    cells = np.stack([rows, cols], axis=1).astype(np.int32)
    groups = np.split(cells, np.cumsum(sizes)[:-1])
    return [g for g in groups if len(g) >= min_size]


def detect(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
           costmap: np.ndarray, robot_cell: Cell, settings: FrontierSettings = FrontierSettings(),
           cost_to_come: Optional[np.ndarray] = None, tried: Tried = Tried(),
           spent: Optional[np.ndarray] = None) -> List[Frontier]:
    """Frontiers of ``occupancy`` with goals, gains and path costs from ``robot_cell``.

    occupancy: int8 (rows, cols); resolution: m per cell; origin: (x, y[, yaw]) of cell
    (0, 0)'s corner, yaw ignored; costmap: uint8 inflated costmap of the same map (Nav2
    values); robot_cell: (row, col) of the robot. cost_to_come: float32 (rows, cols) field
    from the robot (e.g. ``dijkstra`` with the caller's visit penalty); by default
    ``dijkstra(costmap, robot_cell)``, computed once here. If the robot's cell is impassable
    (inscribed, when it brushes a wall), that field starts from the nearest passable cell
    within ``snap_radius_m``; with none, every frontier is unreachable. tried: the goals
    reached so far (``GoalBook.tried``): a snapped goal in a tried disc gives way to a
    viewpoint that sees what the reached goals did not (``viewpoints``). spent: bool (rows,
    cols), cells that are no frontier however unknown (``Looks.spent``: looked at enough).
    """
    occupancy = np.asarray(occupancy)
    if occupancy.ndim != 2:
        raise ValueError(f"detect: occupancy must be 2-D, got {occupancy.ndim}-D")
    occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
    costmap = np.ascontiguousarray(costmap, dtype=np.uint8)
    if costmap.shape != occupancy.shape:
        raise ValueError(f"detect: costmap has shape {costmap.shape}, occupancy "
                         f"{occupancy.shape}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"detect: resolution must be a positive number of metres, got "
                         f"{resolution}")
    robot_cell = (int(robot_cell[0]), int(robot_cell[1]))
    if cost_to_come is None:
        cost_to_come = robot_cost_to_come(costmap, robot_cell, resolution, settings.snap_radius_m)
    else:
        cost_to_come = np.asarray(cost_to_come)
        if cost_to_come.shape != occupancy.shape:
            raise ValueError(f"detect: cost_to_come has shape {cost_to_come.shape}, occupancy "
                             f"{occupancy.shape}")

    frontier = find_frontier_cells(occupancy, opening_cells=settings.min_opening_cells)
    if spent is not None:
        if np.shape(spent) != occupancy.shape:
            raise ValueError(f"detect: spent has shape {np.shape(spent)}, occupancy "
                             f"{occupancy.shape}")
        frontier &= ~np.asarray(spent, dtype=bool)
    clusters = cluster(frontier, settings.min_size_cells)
    if not clusters:
        return []
    unknown = occupancy < 0
    robot = np.array(robot_cell, dtype=float)
    viewpoints = Viewpoints(occupancy, costmap, cost_to_come, frontier, resolution, origin, tried,
                            settings.sensor_range_m / resolution, settings.gain_beams,
                            FREE_THRESH, settings.max_cost)
    snaps: List[Tuple[Cell, bool]] = []
    for cells in clusters:
        representative = _representative_cell(cells)
        target = _extend_into_unknown(representative, robot, unknown,
                                      settings.extend_into_unknown_m / resolution)
        snaps.append(_snap(costmap, cost_to_come, [target, representative], settings,
                           resolution))
    # A snapped goal in a tried disc gives way to another viewpoint at once; a frontier the
    # snap finds nothing for is looked at once no frontier is left to drive to.
    tried_snap = [reachable and tried.covers(cell_to_xy(goal, resolution, origin))
                  for goal, reachable in snaps]
    drive = any(reachable and not t for (_, reachable), t in zip(snaps, tried_snap))
    goals: List[Tuple[Cell, bool]] = []
    for cells, (goal, reachable), t in zip(clusters, snaps, tried_snap):
        if t or not (reachable or drive):
            view = viewpoints.find(cells)
            goal, reachable = (goal, False) if view is None else (view, True)
        goals.append((goal, reachable))
    gains = _native.visible_unknown(occupancy, np.array([g for g, _ in goals], dtype=np.int32),
                                    settings.sensor_range_m / resolution,
                                    beams=settings.gain_beams,
                                    free_threshold=FREE_THRESH)

    frontiers = []
    for i, (cells, (goal_cell, reachable), gain) in enumerate(zip(clusters, goals, gains)):
        cells.setflags(write=False)
        nearest = cells[np.argmin(((cells - robot) ** 2).sum(axis=1))]
        frontiers.append(Frontier(
            id=i, cells=cells, size=len(cells), length_m=len(cells) * resolution,
            centroid=cell_to_xy(cells.mean(axis=0), resolution, origin),
            closest=cell_to_xy(nearest, resolution, origin),
            goal=cell_to_xy(goal_cell, resolution, origin), goal_cell=goal_cell, gain=int(gain),
            path_cost_m=float(cost_to_come[goal_cell]) if reachable else math.inf,
            reachable=reachable))
    return frontiers


def robot_cost_to_come(costmap: np.ndarray, robot_cell: Cell, resolution: float,
                       snap_radius_m: float) -> np.ndarray:
    """The cost-to-come field ``detect`` builds by default, for callers that need it first
    (the explorer hands it to ``detect`` and to the strategies): Dijkstra (float32, m) from
    ``robot_cell`` on ``costmap``, or from the nearest passable cell (cost below inscribed)
    within ``snap_radius_m`` (path length) when the robot's own cell is impassable (it brushes
    a wall) or off the grid; all +inf if there is none."""
    r, c = robot_cell
    rows, cols = costmap.shape
    start: Optional[Cell] = robot_cell
    if not (0 <= r < rows and 0 <= c < cols and costmap[r, c] < INSCRIBED):
        start = nearest_accessible(costmap, robot_cell, max_cost=INSCRIBED - 1,
                                   max_radius_m=snap_radius_m, resolution=resolution)
    if start is None:
        return np.full(costmap.shape, np.inf, dtype=np.float32)
    return dijkstra(costmap, tuple(start), resolution=resolution)


# ------------------------------------------------------------------------------------ steps

def _representative_cell(cells: np.ndarray) -> Cell:
    """The cluster's cell nearest its centroid (first in raster order on ties)."""
    offsets = cells - cells.mean(axis=0)
    r, c = cells[np.argmin((offsets ** 2).sum(axis=1))]
    return int(r), int(c)


def _extend_into_unknown(cell: Cell, robot: np.ndarray, unknown: np.ndarray,
                         extension_cells: float) -> Cell:
    """``cell`` moved up to ``extension_cells`` further along robot -> cell, in whole-cell
    steps, as far as every step lands on an unknown cell of the grid (seed 004)."""
    direction = np.asarray(cell, dtype=float) - robot
    norm = float(np.hypot(*direction))
    steps = int(math.floor(extension_cells + 1e-9))
    if steps == 0 or norm == 0.0:
        return cell
    k = np.arange(1, steps + 1, dtype=float)[:, None]
    samples = np.floor(np.asarray(cell, dtype=float) + k * direction / norm + 0.5).astype(int)
    on_grid = inside(samples[:, 0], samples[:, 1], unknown.shape)
    ok = on_grid.copy()
    ok[on_grid] = unknown[samples[on_grid, 0], samples[on_grid, 1]]
    run = steps if ok.all() else int(np.argmin(ok))  # leading steps that stay in unknown
    if run == 0:
        return cell
    return int(samples[run - 1, 0]), int(samples[run - 1, 1])


def _snap(costmap: np.ndarray, cost_to_come: np.ndarray, targets: Sequence[Cell],
          settings: FrontierSettings, resolution: float) -> Tuple[Cell, bool]:
    """(goal cell, reachable). For each target in turn (the extended point, then the
    representative one), the cell nearest to it by a path within snap_radius_m
    (_distance_from) that the robot can stand on and reach: a finite cost-to-come and a known
    cost <= max_cost (if there is none for any target: the cheapest cost the robot can reach
    near any target), or unknown (255) where the caller's field crosses unknown space (a
    planner with unknown_cost >= 0, like Nav2's allow_unknown in seed 004). With none, an
    unreachable goal for the report: the nearest cell it could stand on, else the
    representative cell itself. Ties go to the smaller row, then column."""
    fallback: Optional[Cell] = None
    walks = [(target, *_distance_from(costmap, target, settings, resolution))
             for target in dict.fromkeys(targets)]   # unique, in order
    near = [distance <= settings.snap_radius_m + 1e-9 for _, _, distance in walks]
    reached = [np.isfinite(cost_to_come[window]) for _, window, _ in walks]
    # max_cost first. Where no cell that cheap is near (a corridor barely wider than the robot
    # has none), the cheapest cost the robot can reach near the target: the corridor's centre
    # line, not the edge of the band along its wall, where one wall cell more in the next map
    # makes the goal impassable. The robot turns in place safely on any passable cell (the
    # inscribed radius is the circumscribed one).
    cheapest = min((int(costmap[window][n & r].min(initial=INSCRIBED))
                    for (_, window, _), n, r in zip(walks, near, reached)), default=INSCRIBED)
    for max_cost in dict.fromkeys((settings.max_cost, min(cheapest, INSCRIBED - 1))):
        for (target, window, distance), n, r in zip(walks, near, reached):
            cost = costmap[window]
            standable = cost <= max_cost
            goal = _nearest(distance, n & (standable | (cost == NO_INFORMATION)) & r, window)
            if goal is not None:
                return goal, True
    for (target, window, distance), n in zip(walks, near):
        fallback = _nearest(distance, n & (costmap[window] < INSCRIBED), window)
        if fallback is not None:
            break
    return (targets[-1] if fallback is None else fallback), False


def _distance_from(costmap: np.ndarray, target: Cell, settings: FrontierSettings,
                   resolution: float) -> Tuple[Tuple[slice, slice], np.ndarray]:
    """Path distance (m, 8-connected, float32) from ``target`` over the cells of the window
    of radius snap_radius_m around it, moving only on cells the robot can pass (cost below
    inscribed) or unknown. The goal must stand on a cell <= max_cost, but the walk to it may
    cross the band along walls: a frontier in a tight spot (beside a pillar in an alcove) is
    bordered by such cells, and a walk confined to max_cost cells would find no goal for it
    although the robot can drive there.

    Seed 001 snaps to the nearest accessible cell by straight-line distance, which jumps
    walls: a frontier behind a gap narrower than the robot would borrow a goal in the
    robot's room on the other side of the wall and look reachable. Measured along cells the
    robot could stand on (or has not seen), the goal stays on the frontier's side."""
    rows, cols = costmap.shape
    k = int(math.ceil(settings.snap_radius_m / resolution))  # path >= straight-line distance
    r0, c0 = target
    window = (slice(max(r0 - k, 0), min(r0 + k + 1, rows)),
              slice(max(c0 - k, 0), min(c0 + k + 1, cols)))
    cost = costmap[window]
    passable = (cost < INSCRIBED) | (cost == NO_INFORMATION)
    local = np.where(passable, FREE_SPACE, LETHAL).astype(np.uint8)
    start = (r0 - window[0].start, c0 - window[1].start)
    local[start] = FREE_SPACE  # the target (a frontier cell, unknown) is where the walk begins
    return window, dijkstra(local, start, resolution=resolution)


def _nearest(distance: np.ndarray, ok: np.ndarray, window: Tuple[slice, slice]) -> Optional[Cell]:
    """The ``ok`` cell of the window with the smallest distance, in grid coordinates (the
    first in raster order on ties), or None."""
    if not ok.any():
        return None
    i, j = np.unravel_index(np.argmin(np.where(ok, distance, np.inf)), ok.shape)
    return int(window[0].start + i), int(window[1].start + j)
