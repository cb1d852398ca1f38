"""Viewpoints: the cells from which the robot sees a frontier, by line of sight.

A frontier's goal is a viewpoint: a cell the robot can stand on and reach from which some of
the frontier's cells are visible. ``frontiers.detect`` first snaps the frontier to the
nearest such cell by path length (``_snap``, which also crosses unknown space); where that
cell was already tried, and (once no frontier has a snapped goal left) where the snap finds
nothing (a frontier seen through a gap narrower than the robot, or in a field of clutter),
the goal comes from this module instead.

1. Spent cells. A goal the robot reached has spent its view: a frontier cell that a ray
   from it reaches and that is still unknown is not revealed by looking from there again
   (it lies between two beams, or at the edge of the range; if the map has simply not
   caught up with the arrival yet, the frontier is gone with the next map). The frontier's
   surviving cells are its cells less the spent ones: those clutter hid from every reached
   goal.
2. Sight. A ray runs from a surviving cell over known-free cells (occupied and unknown
   cells stop it) within ``sensor_range_m``: the rays of the information gain
   (``_native.visible_cells``, ``gain_beams`` Bresenham rays), cast from the frontier
   outward, all of its cells in one call, so the result is every cell that sees some of
   them. (The reverse of the lidar's rays: the same lines up to Bresenham's rounding.)
3. Candidates: cells that see a surviving cell, reachable (finite cost-to-come), outside
   every tried disc (within ``Tried.radius_m`` of a reached goal: a new viewpoint looks from
   a place not yet tried), of cost <= ``max_cost`` (if none is, any cost below inscribed:
   the robot turns in place safely on any passable cell).
4. Choice: the candidate nearest the surviving cells (a lidar sees best from near), then
   nearest their centroid (the middle of a straight frontier rather than its end), then the
   first in raster order. No candidate: the frontier is given up.

``Looks`` spends frontier cells the same way from where the robot has been, not only where it
stopped: an unknown cell that the lidar's rays reached, in line of sight over known-free
cells within ``look_range_m``, from ``looks_to_spend`` places ``look_spacing_m`` apart, and
that the map still shows unknown, is one the lidar does not reveal (a wall's face drawn a
cell off, a corner between two wall cells that a Bresenham line slips through): no frontier.
Open space within that range is always revealed (the mapper clears along beams without a
return up to ``no_return_clear_m``, beyond ``look_range_m``), so a frontier into it never
goes this way. Without it, the end of a run is spent driving to such cells, which a SLAM map
makes anew at each redraw (a house's last 400 s of 960 after 99 %, an office's 700 s).

Cells and grids follow ``frontiers``: (row, col), row 0 at the smallest y; points are
metres in the map frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from .. import _native
from ..geometry import cells_to_points, points_to_cells
from ..planning import INSCRIBED

Cell = Tuple[int, int]
Window = Tuple[slice, slice]


@dataclass(frozen=True, eq=False)
class Tried:
    """The goals the robot reached, in map-frame metres (``GoalBook.tried`` builds it)."""
    reached: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # float (n, 2): x, y
    radius_m: float = 0.4                  # a tried disc: no new viewpoint this close to one

    def covers(self, xy: Sequence[float]) -> bool:
        """Whether ``xy`` lies in a tried disc (within radius_m of a reached goal, inclusive)."""
        r = self.reached
        return bool(np.any(np.hypot(r[:, 0] - xy[0], r[:, 1] - xy[1]) <= self.radius_m + 1e-9))


class Looks:
    """Frontier cells the lidar has looked at (module docstring), counted in map-frame cells,
    so that the count survives the grid growing. ``look`` once per explorer cycle with the
    robot's position and the map of that cycle: the position of the previous look is cast on
    it (its scans are in this map), when it lies ``spacing_m`` or more from the last one cast.
    """

    def __init__(self, range_m: float, spacing_m: float, to_spend: int, beams: int,
                 free_threshold: int):
        self.range_m, self.spacing_m, self.to_spend = range_m, spacing_m, to_spend
        self.beams, self.free_threshold = beams, free_threshold
        self.counts: dict = {}                             # (ix, iy) global cell -> looks
        self._pending: Optional[np.ndarray] = None         # the last position, cast next
        self._cast: Optional[np.ndarray] = None            # the last position cast

    def look(self, occupancy: np.ndarray, frontier: np.ndarray, resolution: float,
             origin: Sequence[float], xy: Sequence[float]) -> None:
        """Count the frontier cells (``frontier``, bool) of this map that a ray from the
        pending position reaches; then ``xy`` is pending."""
        pending, self._pending = self._pending, np.asarray(xy[:2], dtype=float)
        if self.to_spend == 0 or pending is None or (
                self._cast is not None and np.hypot(*(pending - self._cast)) < self.spacing_m):
            return
        rows, cols = points_to_cells(pending[None], resolution, origin)
        if not (0 <= rows[0] < occupancy.shape[0] and 0 <= cols[0] < occupancy.shape[1]):
            return
        self._cast = pending
        free = (occupancy >= 0) & (occupancy <= self.free_threshold)
        r, c = np.nonzero(_frontier_in_view(free, frontier, np.array([[rows[0], cols[0]]]),
                                            self.range_m / resolution, self.beams))
        base = _base(resolution, origin)
        for key in zip((c + base[0]).tolist(), (r + base[1]).tolist()):
            self.counts[key] = self.counts.get(key, 0) + 1

    def spent(self, shape: Tuple[int, int], resolution: float, origin: Sequence[float]) -> np.ndarray:
        """Bool ``shape``: the cells looked at ``to_spend`` times or more."""
        out = np.zeros(shape, dtype=bool)
        keys = [k for k, n in self.counts.items() if n >= self.to_spend] if self.to_spend else []
        if keys:
            base = _base(resolution, origin)
            ix, iy = np.array(keys).T
            r, c = iy - base[1], ix - base[0]
            ok = (r >= 0) & (r < shape[0]) & (c >= 0) & (c < shape[1])
            out[r[ok], c[ok]] = True
        return out


def _base(resolution: float, origin: Sequence[float]) -> Tuple[int, int]:
    """The global index (ix, iy) of cell (0, 0): the map's origin in whole cells (the mapper's
    grid grows by whole cells, so its origin stays on one lattice)."""
    return round(float(origin[0]) / resolution), round(float(origin[1]) / resolution)


class Viewpoints:
    """The viewpoint search over one map (shared by every frontier of one ``detect`` call).

    occupancy: int8 ROS values; costmap: uint8 inflated costmap; cost_to_come: float32 field
    from the robot (m); frontier: bool mask of every frontier cell (rays pass through them
    when they look for spent cells: an unknown cell that borders free space is what a lidar
    looks into); resolution (m per cell) and origin ((x, y) m of cell (0, 0)'s corner) place
    the tried goals; range_cells, beams: the sight model (``sensor_range_m / resolution``,
    ``gain_beams``); free_threshold: occupancy 0..this is free; max_cost: the preferred goal
    cost.
    """

    def __init__(self, occupancy: np.ndarray, costmap: np.ndarray, cost_to_come: np.ndarray,
                 frontier: np.ndarray, resolution: float, origin: Sequence[float], tried: Tried,
                 range_cells: float, beams: int, free_threshold: int, max_cost: int):
        self.occupancy, self.free_threshold = occupancy, free_threshold
        self.frontier, self.costmap, self.cost_to_come = frontier, costmap, cost_to_come
        self.resolution, self.origin, self.tried = resolution, origin, tried
        self.range_cells, self.beams, self.max_cost = range_cells, beams, max_cost
        rows, cols = points_to_cells(tried.reached, resolution, origin)
        self.reached = np.stack([rows, cols], axis=1).reshape(-1, 2)

    @cached_property
    def free(self) -> np.ndarray:
        """Bool (rows, cols): known-free cells (computed at the first search of a detection)."""
        return (self.occupancy >= 0) & (self.occupancy <= self.free_threshold)

    def find(self, cells: np.ndarray) -> Optional[Cell]:
        """The viewpoint of the frontier made of ``cells`` (int (n, 2)), or None: steps 1-4
        of the module docstring, on the window of the grid within range of the cells."""
        window, offset = self._window(cells)
        mine = np.zeros(_shape(window), dtype=bool)
        mine[cells[:, 0] - offset[0], cells[:, 1] - offset[1]] = True
        # 1. surviving cells
        surviving = mine & ~self._spent(window, offset)
        if not surviving.any():
            return None
        targets = np.argwhere(surviving).astype(np.int32)
        # 2. every cell that sees one of them
        blocking = np.ascontiguousarray(~self.free[window], dtype=np.uint8)
        sees = _native.visible_cells(blocking, targets, self.range_cells, beams=self.beams)
        # 3. candidates
        cost = self.costmap[window]
        ok = (sees & np.isfinite(self.cost_to_come[window]) & (cost < INSCRIBED)
              & ~self.in_discs[window])
        if (ok & (cost <= self.max_cost)).any():
            ok &= cost <= self.max_cost
        if not ok.any():
            return None
        # 4. nearest the surviving cells, then their centroid, then in raster order
        index = np.flatnonzero(ok)
        r, c = np.divmod(index, ok.shape[1])
        to_cells = ndimage.distance_transform_edt(~surviving).ravel()[index]
        centroid = targets.mean(axis=0)
        to_centroid = np.hypot(r - centroid[0], c - centroid[1])
        best = np.lexsort((to_centroid, to_cells))[0]     # stable: ties keep raster order
        return int(offset[0] + r[best]), int(offset[1] + c[best])

    def _window(self, cells: np.ndarray) -> Tuple[Window, np.ndarray]:
        """The part of the grid within range of the cells (their bounding box grown by the
        range): every cell that can see one of them, and every reached goal that can."""
        k = int(math.ceil(self.range_cells))
        rows, cols = self.occupancy.shape
        r0, c0 = np.maximum(cells.min(axis=0) - k, 0)
        r1, c1 = np.minimum(cells.max(axis=0) + k + 1, (rows, cols))
        return (slice(int(r0), int(r1)), slice(int(c0), int(c1))), np.array([r0, c0])

    def _spent(self, window: Window, offset: np.ndarray) -> np.ndarray:
        """Bool (window): the frontier cells that a ray from a reached goal reaches, over
        known-free and frontier cells."""
        shape = _shape(window)
        local = self.reached - offset
        inside = ((local >= 0) & (local < shape)).all(axis=1)
        if not inside.any():
            return np.zeros(shape, dtype=bool)
        return _frontier_in_view(self.free[window], self.frontier[window], local[inside],
                                 self.range_cells, self.beams)

    @cached_property
    def in_discs(self) -> np.ndarray:
        """Bool (rows, cols): cells whose centre lies in a tried disc (each disc marked over
        its bounding box only)."""
        out = np.zeros(self.occupancy.shape, dtype=bool)
        radius = self.tried.radius_m
        k = int(math.ceil(radius / self.resolution)) + 1
        for (x, y), (r, c) in zip(self.tried.reached, self.reached):
            rows = slice(max(int(r) - k, 0), max(int(r) + k + 1, 0))
            cols = slice(max(int(c) - k, 0), max(int(c) + k + 1, 0))
            box = np.indices(out[rows, cols].shape).transpose(1, 2, 0) + (rows.start, cols.start)
            xy = cells_to_points(box, self.resolution, self.origin)
            out[rows, cols] |= np.hypot(xy[..., 0] - x, xy[..., 1] - y) <= radius + 1e-9
        return out


def _frontier_in_view(free: np.ndarray, frontier: np.ndarray, sources: np.ndarray,
                      range_cells: float, beams: int) -> np.ndarray:
    """Bool: the frontier cells that a ray from one of ``sources`` (int (n, 2) cells) reaches
    within ``range_cells`` over known-free and frontier cells (a frontier cell is what a lidar
    looks into)."""
    blocking = np.ascontiguousarray(~(free | frontier), dtype=np.uint8)
    seen = _native.visible_cells(blocking, np.asarray(sources, dtype=np.int32), range_cells,
                                 beams=beams)
    return seen & frontier


def _shape(window: Window) -> Tuple[int, int]:
    return window[0].stop - window[0].start, window[1].stop - window[1].start
