"""Coverage (DESIGN §6): the reachable free space F of a world (seen from where the robot's
footprint can go), and the fraction of F that the robot's map has observed over time.

Frames: F is a grid over the world (``World.free``'s cells, world frame). The robot's map is in
its own ``map`` frame, whose origin is the start pose; ``map_to_world`` (x, y, yaw) is that pose
in the world, known to the evaluator only.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .. import _native
from ..geometry import cells_to_points, inside, inverse, points_to_cells, transform_points
from ..mapping.map_io import FREE_THRESH, OCCUPIED_THRESH
from ..planning.lattice import LatticeSettings, lattice_cost_to_come
from ..robot import RobotSpec
from ..sim.world import World

LATTICE_M = 0.25        # viewpoint spacing for F (DESIGN §6)
LIDAR_BEAMS = 360       # rays per viewpoint: the LDS-01's beam count (DESIGN §5); the
                        # viewpoints' overlap fills the gaps between rays (720 or 1440 beams
                        # give the same F on every shipped world)
MILESTONES = (0.90, 0.95, 0.99)


def reachable_cells(world: World, robot: RobotSpec,
                    lattice: LatticeSettings = LatticeSettings()) -> np.ndarray:
    """Cells the robot's centre can reach (DESIGN §6): those the navigator's state lattice
    reaches from the world's start on the true map with ``robot``'s footprint
    (``lattice_cost_to_come`` finite): a disc robot where its disc fits, a box robot driving
    straight through any gap its box fits and turning in place only where its turning disc
    fits, starting as the navigator does (the nearest cell within 0.5 m where it fits).
    The explorer's reachability and the oracle's. bool (rows, cols), world grid.

    ValueError if the robot fits nowhere near the start."""
    # turns_within_m=0: which cells are finite does not depend on it, and without the turns'
    # costs a cell where the robot can turn is one search node, not one per heading (0.1 s
    # instead of seconds on the largest worlds)
    field = lattice_cost_to_come(world.occupancy(), world.resolution, world.origin, robot,
                                 world.start, lattice, turns_within_m=0.0)
    reach = np.isfinite(field)
    if not reach.any():
        raise ValueError(f"{world.path}: the start ({world.start[0]:.3f}, {world.start[1]:.3f}) has "
                         f"no cell within 0.5 m where {robot.name}'s footprint fits")
    return reach


def lattice_points(reachable: np.ndarray, step_cells: int) -> np.ndarray:
    """One viewpoint per ``step_cells`` x ``step_cells`` block that holds reachable cells: the
    reachable cell nearest the block's centre (ties: lowest row, then column). int32 (n, 2).

    A block per viewpoint, rather than the fixed cells (k step, l step), keeps a viewpoint in
    every stretch of a corridor whose reachable band is narrower than the step.
    """
    if step_cells < 1:
        raise ValueError(f"step_cells must be >= 1, got {step_cells}")
    rr, cc = np.nonzero(reachable)          # row-major order: ties go to the lowest (row, col)
    if rr.size == 0:
        return np.zeros((0, 2), np.int32)
    br, bc = rr // step_cells, cc // step_cells
    block = br * (reachable.shape[1] // step_cells + 1) + bc
    centre = (step_cells - 1) / 2.0
    d2 = (rr - br * step_cells - centre) ** 2 + (cc - bc * step_cells - centre) ** 2
    order = np.lexsort((d2, block))         # by block, then distance; stable for ties
    first = np.unique(block[order], return_index=True)[1]
    pick = order[first]
    return np.stack([rr[pick], cc[pick]], axis=1).astype(np.int32)


def visible_free_space(world: World, reachable: np.ndarray, sensor_range_m: float,
                       lattice_m: float = LATTICE_M, beams: int = LIDAR_BEAMS) -> np.ndarray:
    """The free cells a lidar of range ``sensor_range_m`` sees (line of sight, Bresenham rays,
    ``beams`` per viewpoint) from one viewpoint per ``lattice_m`` square of the ``reachable``
    cells (``lattice_points``). bool (rows, cols), world grid."""
    if not (math.isfinite(sensor_range_m) and sensor_range_m > 0):
        raise ValueError(f"sensor_range_m must be a finite number > 0, got {sensor_range_m}")
    if not (math.isfinite(lattice_m) and lattice_m > 0):
        raise ValueError(f"lattice_m must be a finite number > 0, got {lattice_m}")
    step = max(1, int(round(lattice_m / world.resolution)))
    points = lattice_points(reachable, step)
    solid = world.solid.astype(np.uint8)
    radius = sensor_range_m / world.resolution
    # Coarse to fine: the viewpoints of every 4th block, then every 2nd, then the rest, each
    # pass only those with a free cell not yet seen within range (nothing else can add to F:
    # a viewpoint sees no cell farther than the range). The same F as casting from all of
    # them, 3-4x faster on the office and the warehouse, whose open floors are seen at once.
    blocks = points // step
    seen = np.zeros(world.free.shape, bool)
    done = np.zeros(len(points), bool)
    for stride in (4, 2, 1):
        take = ~done & np.all(blocks % stride == 0, axis=1)
        if seen.any():
            near = ndimage.distance_transform_edt(~(world.free & ~seen)) <= radius
            take &= near[points[:, 0], points[:, 1]]
        seen |= _native.visible_cells(solid, points[take], radius, beams=beams)
        done |= np.all(blocks % stride == 0, axis=1)
    return seen & world.free


def reachable_free_space(world: World, robot: RobotSpec, sensor_range_m: float,
                         lattice: LatticeSettings = LatticeSettings(),
                         lattice_m: float = LATTICE_M, beams: int = LIDAR_BEAMS) -> np.ndarray:
    """F (DESIGN §6): the free cells the robot's lidar (range ``sensor_range_m``) sees from the
    cells it can reach with its footprint (``reachable_cells``: the navigator's lattice with
    ``lattice``), one viewpoint per ``lattice_m`` square (``visible_free_space``). bool (rows,
    cols), world grid. Compute it once per run: about 0.3 s on the office, 2 s on worldgen's
    85 x 50 m warehouse."""
    return visible_free_space(world, reachable_cells(world, robot, lattice), sensor_range_m,
                              lattice_m, beams)


def world_to_map(xy: np.ndarray, start: tuple) -> np.ndarray:
    """World points (n, 2) -> the robot's map frame, whose origin is the start pose (x, y, yaw)."""
    x0, y0, yaw = start
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = xy[:, 0] - x0, xy[:, 1] - y0
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy])


def map_values_at(mx: np.ndarray, my: np.ndarray, occupancy: np.ndarray, resolution: float,
                  origin_xy: tuple, outside: int = -1) -> np.ndarray:
    """int16, the shape of ``mx``: the map's value (ROS int8: -1 unknown, 0..100) of the cell
    under each map-frame point (m), row 0 at ``origin_xy``; ``outside`` for points off the map."""
    rows, cols = points_to_cells(np.stack([mx, my], axis=-1), resolution, origin_xy)
    on_map = inside(rows, cols, occupancy.shape)
    values = np.full(rows.shape, outside, dtype=np.int16)
    values[on_map] = occupancy[rows[on_map], cols[on_map]]
    return values


def free_at(mx: np.ndarray, my: np.ndarray, occupancy: np.ndarray, resolution: float,
            origin_xy: tuple) -> np.ndarray:
    """bool, the shape of ``mx``: whether the map (int8 ROS values, row 0 at ``origin_xy``)
    marks the cell under each map-frame point (m) free; points off the map are not."""
    v = map_values_at(mx, my, occupancy, resolution, origin_xy)
    return (v >= 0) & (v <= FREE_THRESH)


def wall_face(world: World) -> np.ndarray:
    """bool (rows, cols): the free cells within one cell of a true obstacle (their centre no
    more than ``resolution`` from a solid cell's square: the 8 neighbours of a solid cell;
    outside the image is solid, as ``World.clearance`` has it)."""
    return world.free & (world.clearance() <= world.resolution)


# Where an F cell is sampled, in world cells from its centre: the centre and a point near each
# corner. DESIGN §6 samples the centre only; that scores a perfect map below 100 % whenever the
# robot's grid is not aligned with the world's (a start pose off the world's cell corners, a
# yaw not a multiple of 90 deg): a centre then lies on a boundary of the robot's cells, and at
# a wall face the cell it picks straddles the wall. "Some part of the cell's square is mapped
# free" is the same test for an aligned grid and does not depend on the alignment.
SAMPLE_OFFSETS = ((0.0, 0.0), (-0.45, -0.45), (-0.45, 0.45), (0.45, -0.45), (0.45, 0.45))


class CoverageTracker:
    """Coverage(t) (DESIGN §6): the fraction of F that the robot's map has observed. Each F cell
    is sampled at its centre and near its corners (``SAMPLE_OFFSETS``). A cell on a wall's face
    (``wall_face``: within one cell of a true obstacle) is covered when the map knows any of its
    sample points, free or occupied: range noise puts about half the hits in front of a wall
    face and a hit outweighs a miss, so a face the lidar has swept often reads occupied, and a
    wall SLAM draws a few centimetres off still shows that its face was seen (map accuracy is
    judged apart: map precision, ATE). Every other cell is covered when the map marks one of
    its sample points free (0..25). Cells of F outside the robot's map count as not covered."""

    def __init__(self, world: World, reachable_free: np.ndarray, map_to_world: tuple | None = None):
        if reachable_free.shape != world.free.shape:
            raise ValueError(f"F has shape {reachable_free.shape}, the world {world.free.shape}")
        rows, cols = np.nonzero(reachable_free)
        if rows.size == 0:
            raise ValueError("F is empty: nothing to cover")
        centres = cells_to_points(np.column_stack([rows, cols]), world.resolution, world.origin)
        offsets = np.asarray(SAMPLE_OFFSETS, float) * world.resolution           # (k, 2) m
        points = centres[None, :, :] + offsets[:, None, :]                       # (k, |F|, 2), world
        # world -> map: the inverse of map_to_world (default: the world's start pose).
        m = world_to_map(points.reshape(-1, 2), world.start if map_to_world is None else map_to_world)
        self._mx, self._my = m[:, 0].reshape(points.shape[:2]), m[:, 1].reshape(points.shape[:2])
        self.face = wall_face(world)[rows, cols]      # (|F|,) bool
        self.cells = int(rows.size)
        self.area_m2 = self.cells * world.resolution ** 2
        self._t: list = []
        self._fraction: list = []

    def covered(self, occupancy: np.ndarray, resolution: float, origin_xy: tuple,
                alignment: tuple | None = None) -> np.ndarray:
        """bool (|F|,): whether the robot's map (int8 ROS values, row 0 at ``origin_xy``, map
        frame, m) has observed each F cell: a wall-face cell known at one of its sample points,
        any other marked free at one. ``alignment`` (x, y, yaw): the rigid motion taking the
        robot's map frame onto the true one (a SLAM map's best fit to the ground truth; the map
        is then read where it put each sample point)."""
        mx, my = self._mx, self._my
        if alignment is not None:
            pts = transform_points(inverse(alignment), np.column_stack([mx.ravel(), my.ravel()]))
            mx, my = pts[:, 0].reshape(mx.shape), pts[:, 1].reshape(my.shape)
        v = map_values_at(mx, my, occupancy, resolution, origin_xy)
        known = (v >= 0).any(axis=0)
        free = ((v >= 0) & (v <= FREE_THRESH)).any(axis=0)
        return np.where(self.face, known, free)

    def seen(self, occupancy: np.ndarray, resolution: float, origin_xy: tuple) -> tuple:
        """(known, occupied): the shares of F whose centre the robot's map marks known (free or
        occupied: observed, whatever the mapper concluded) and occupied (>= 65). Away from the
        walls coverage counts only free; an occupied cell there is a mapping error."""
        v = map_values_at(self._mx[0], self._my[0], occupancy, resolution, origin_xy)   # SAMPLE_OFFSETS[0]: centres
        return float(np.mean(v >= 0)), float(np.mean(v >= OCCUPIED_THRESH))

    def update(self, t_s: float, occupancy: np.ndarray, resolution: float, origin_xy: tuple) -> float:
        """Sample the robot's map at sim time ``t_s`` (s); append and return the coverage."""
        fraction = float(np.count_nonzero(self.covered(occupancy, resolution, origin_xy))) / self.cells
        self._t.append(float(t_s))
        self._fraction.append(fraction)
        return fraction

    def time_to(self, fraction: float) -> float | None:
        """The first sampled sim time (s) at which coverage reached ``fraction``; None if never."""
        t, f = self.series
        hit = np.flatnonzero(f >= fraction)
        return float(t[hit[0]]) if hit.size else None

    @property
    def final(self) -> float | None:
        """The last sampled coverage; None before the first update."""
        return self._fraction[-1] if self._fraction else None

    @property
    def series(self) -> tuple:
        """(t_s, fraction): two float arrays of the samples so far."""
        return np.asarray(self._t, float), np.asarray(self._fraction, float)

    def summary(self) -> dict:
        """The coverage keys of report.json: coverage_final, time_to_90_s, _95_s, _99_s."""
        out = {"coverage_final": self.final}
        for m in MILESTONES:
            out[f"time_to_{round(100 * m)}_s"] = self.time_to(m)
        return out
