"""The 3-D obstacle layer: settings and facade of the C++ ``_native.OctomapLayer`` (OctoMap).

Point clouds (a depth camera's, perception.depth; a lidar's at its mounting height) go into
an octomap::OcTree by OctoMap's ray casting; the occupied voxels between the floor band and
the robot's top are projected onto the lidar grid's geometry as an int8 layer: 100 under such
a voxel, -1 everywhere else. The layer holds obstacles only: a depth camera sees a column of
space at some heights and not others, so "no voxel here" is never "free here".

How it joins the 2-D map (``merge_obstacles``): a cell-wise maximum with the lidar grid
(-1 unknown, 0..100). Under a 3-D obstacle the cell becomes 100, whatever the lidar said
(its beams pass over a low box, under a shelf); everywhere else the lidar's value stays,
unknown included. The costmap (planning.costmap.make_costmap) and the lattice
(planning.lattice) read the merged grid as they read the lidar's, so both inflate and avoid
the box like a wall. The layer is projected again from the tree each time, so an obstacle
that the camera later sees gone (its voxels cleared by rays through them) leaves the map.

Frames and units: points and origins in metres in the map frame, z up, the floor at z = 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from scipy import ndimage

from .. import _native
from ..config import positive, require
from ..robot import RobotSpec
from .map_io import OCCUPIED_THRESH

OBSTACLE = 100   # the layer's value under a 3-D obstacle (nav_msgs/OccupancyGrid's "occupied")
EIGHT = np.ones((3, 3), bool)   # 8-connected neighbourhood


@dataclass(frozen=True)
class OctomapSettings:
    """The OctoMap layer's parameters (config/octomap.yaml)."""
    resolution_m: float = 0.05         # m, finest voxel edge (the lidar grid's cell: one voxel a cell)
    max_range_m: float = 4.0           # m, points farther clear their ray up to here and mark
                                       # nothing (the TurtleBot 2's Astra/Kinect reach, DESIGN §5)
    max_point_z_m: float = 0.45        # m, higher points are not inserted (octomap_server's
                                       # pointcloud_max_z): the free space of rays rising above
                                       # the robot is most of a frame's cost (4 m range, 160 x
                                       # 120: 83-99 ms of CPU without the limit, 17-24 ms with
                                       # it) and none of the layer's concern; >= robot_height_m
                                       # (the TurtleBot 2's 0.40 m and one voxel)
    discretize: bool = True            # OctoMap's option: one ray per end voxel, not per point
                                       # (the same voxels hit; fewer rays)
    floor_band_m: float = 0.03         # m, voxels centred at or below this are the floor
    robot_height_m: float = 0.0        # m, voxels centred above this pass over the robot;
                                       # 0: the robot's body_height_m (with_robot)
    depth_columns: int = 160           # px, a depth image is sampled every width // this pixels
                                       # (640 x 480 → 160 x 120)
    prob_hit: float = 0.7              # OctoMap's sensor model, its defaults: a point's end voxel
    prob_miss: float = 0.4             # votes prob_hit, a crossed voxel prob_miss
    clamping_thres_min: float = 0.1192  # a voxel never surer than this of free ...
    clamping_thres_max: float = 0.971  # ... nor of occupied
    occupancy_thres: float = 0.5       # occupied above this probability
    hidden_extent_m: float = 1.0       # m, how far a 3-D obstacle the lidar cannot see (a table
                                       # top above its plane) is taken to go on into lidar-free
                                       # cells whose band the camera has not seen at its height:
                                       # its far side, hidden behind the face the camera saw,
                                       # blocks until the camera looks (0: off; furniture depth)

    def validate(self, src: str) -> None:
        positive(src, self, "resolution_m", "max_range_m", "max_point_z_m", "depth_columns")
        require(math.isfinite(self.hidden_extent_m) and self.hidden_extent_m >= 0, src, "hidden_extent_m",
                f"must be >= 0 m (0: off), got {self.hidden_extent_m!r}")
        require(math.isfinite(self.floor_band_m) and self.floor_band_m >= 0, src, "floor_band_m",
                f"must be >= 0, got {self.floor_band_m!r}")
        require(math.isfinite(self.robot_height_m) and self.robot_height_m >= 0, src, "robot_height_m",
                f"must be >= 0 (0: the robot's body height), got {self.robot_height_m!r}")
        require(self.robot_height_m == 0 or self.robot_height_m > self.floor_band_m, src, "robot_height_m",
                f"must be above floor_band_m ({self.floor_band_m}), got {self.robot_height_m}")
        require(0.5 < self.prob_hit < 1.0, src, "prob_hit", f"must be in (0.5, 1), got {self.prob_hit}")
        require(0.0 < self.prob_miss < 0.5, src, "prob_miss", f"must be in (0, 0.5), got {self.prob_miss}")
        require(0.0 < self.clamping_thres_min < self.occupancy_thres < self.clamping_thres_max < 1.0,
                src, "occupancy_thres", "need 0 < clamping_thres_min < occupancy_thres < "
                f"clamping_thres_max < 1, got {self.clamping_thres_min}, {self.occupancy_thres}, "
                f"{self.clamping_thres_max}")

    def with_robot(self, robot: RobotSpec) -> "OctomapSettings":
        """These settings with robot_height_m left 0 taken from ``robot``'s body height."""
        return replace(self, robot_height_m=self.robot_height_m or robot.body_height_m)


class OctomapLayer:
    """An OcTree filled from point clouds and projected onto 2-D grids (``settings`` with the
    robot's height resolved: ``OctomapSettings.with_robot``)."""

    def __init__(self, settings: OctomapSettings):
        if settings.robot_height_m <= settings.floor_band_m:
            raise ValueError(f"OctomapLayer: robot_height_m ({settings.robot_height_m} m) must be above "
                             f"floor_band_m ({settings.floor_band_m} m); 0 is resolved by with_robot")
        if settings.max_point_z_m < settings.robot_height_m:
            raise ValueError(f"OctomapLayer: max_point_z_m ({settings.max_point_z_m} m) must be at least "
                             f"robot_height_m ({settings.robot_height_m} m): the band up to the robot's "
                             "top must be seen")
        self.settings = settings
        self.tree = _native.OctomapLayer(
            resolution=settings.resolution_m, prob_hit=settings.prob_hit, prob_miss=settings.prob_miss,
            clamping_thres_min=settings.clamping_thres_min, clamping_thres_max=settings.clamping_thres_max,
            occupancy_thres=settings.occupancy_thres)

    def insert(self, points: np.ndarray, origin) -> _native.CloudStats:
        """Ray-cast ``points`` (n, 3) m, map frame, from the sensor ``origin`` (x, y, z) m. NaN
        and inf points, and points above max_point_z_m, are skipped and counted; an empty
        cloud changes nothing."""
        x, y, z = (float(v) for v in origin)
        s = self.settings
        return self.tree.insert_point_cloud(np.asarray(points, np.float32), x, y, z, s.max_range_m,
                                            s.max_point_z_m, s.discretize)

    def free_body(self, x: float, y: float, radius_m: float) -> int:
        """The robot stands on the disc of ``radius_m`` around (x, y) (m, map frame): the voxels
        of that column up to robot_height_m get a miss each (the camera never sees the space
        its own body fills, so the band along the robot's track would stay unknown)."""
        return self.tree.free_body(float(x), float(y), float(radius_m), self.settings.robot_height_m)

    def project(self, rows: int, cols: int, resolution: float, origin) -> np.ndarray:
        """int8 (rows, cols) on a grid's geometry (row 0 at the smallest y; ``origin`` the (x, y)
        m of cell (0, 0)'s lower-left corner): OBSTACLE under an occupied voxel centred in
        (floor_band_m, robot_height_m], else -1."""
        s = self.settings
        return self.tree.project(rows=rows, cols=cols, resolution=resolution, origin_x=float(origin[0]),
                                 origin_y=float(origin[1]), floor_band_m=s.floor_band_m,
                                 robot_height_m=s.robot_height_m)

    def obstacles(self, occupancy: np.ndarray, resolution: float, origin) -> np.ndarray:
        """The layer to merge with the lidar grid ``occupancy`` (int8, its geometry): ``project``'s
        obstacles, and where one is the layer's own (no lidar wall within a cell: a table top
        above the scan plane, a step below it), the lidar-free cells within hidden_extent_m of
        it, connected to it, whose band the tree has not seen from that obstacle's lowest voxel
        up to the robot's top. The camera sees the near face of such an obstacle, not what lies
        behind it, while the lidar's beams pass under or over and call those cells free; they
        block until a depth frame has looked through them (then their voxels are known, free or
        occupied). Unknown lidar cells stay unknown (they remain frontiers), walls add nothing."""
        rows, cols = occupancy.shape
        layer = self.project(rows, cols, resolution, origin)
        s = self.settings
        solid = layer == OBSTACLE
        if s.hidden_extent_m <= 0 or not solid.any():
            return layer
        wall = occupancy >= OCCUPIED_THRESH
        own = solid & ~ndimage.binary_dilation(wall, EIGHT)
        if not own.any():
            return layer
        lowest = self._lowest_voxel(own, resolution, origin)
        # the distance field in the window of the own obstacles grown by hidden_extent_m: every
        # cell within that distance of one is inside it, and the field there is the whole grid's
        pad = int(np.ceil(s.hidden_extent_m / resolution)) + 1
        on_r, on_c = np.nonzero(own)
        win = (slice(max(on_r.min() - pad, 0), min(on_r.max() + pad + 1, rows)),
               slice(max(on_c.min() - pad, 0), min(on_c.max() + pad + 1, cols)))
        dist, (near_r, near_c) = ndimage.distance_transform_edt(~own[win], return_indices=True)
        r, c = np.nonzero((dist * resolution <= s.hidden_extent_m) & (occupancy[win] >= 0) & ~wall[win] & ~solid[win])
        if r.size == 0:
            return layer
        r0, c0 = win[0].start, win[1].start
        z_from = lowest[near_r[r, c] + r0, near_c[r, c] + c0]    # the nearest own obstacle's lowest voxel
        r, c = r + r0, c + c0
        step = self.tree.resolution
        levels = (np.arange(int(s.robot_height_m / step) + 1) + 0.5) * step
        levels = levels[(levels > s.floor_band_m) & (levels <= s.robot_height_m)]
        xs = origin[0] + (c + 0.5) * resolution
        ys = origin[1] + (r + 0.5) * resolution
        pts = np.stack((np.repeat(xs, levels.size), np.repeat(ys, levels.size), np.tile(levels, r.size)), 1)
        unknown = np.isnan(self.tree.probabilities(pts)).reshape(r.size, levels.size)
        # the nearest own obstacle's lowest level and the two above it: a cell with none of them
        # seen is in its shadow (in front of its face the rays to its lower edge cross them;
        # one seen level is enough, since near the camera the higher ones are out of its view)
        at = np.clip(np.searchsorted(levels, z_from - 0.5 * step), 0, levels.size - 1)
        idx = np.arange(r.size)
        unseen = np.ones(r.size, bool)
        for k in range(3):
            unseen &= unknown[idx, np.minimum(at + k, levels.size - 1)]
        hidden = np.zeros_like(own)
        hidden[r[unseen], c[unseen]] = True
        grown = ndimage.binary_propagation(own, structure=EIGHT, mask=own | hidden)
        layer[grown & ~solid] = OBSTACLE
        return layer

    def _lowest_voxel(self, cells: np.ndarray, resolution: float, origin) -> np.ndarray:
        """float (rows, cols): the lowest centre height (m) of the occupied band voxels over each
        of ``cells`` (bool), +inf elsewhere."""
        s = self.settings
        centres, sizes = self.tree.occupied_voxels()
        low = centres[:, 2] - 0.5 * sizes
        keep = (centres[:, 2] > s.floor_band_m) & (low <= s.robot_height_m)
        centres, sizes = centres[keep], sizes[keep]
        out = np.full(cells.shape, np.inf)
        ci = np.floor((centres[:, 0] - origin[0]) / resolution).astype(int)
        ri = np.floor((centres[:, 1] - origin[1]) / resolution).astype(int)
        ok = (ri >= 0) & (ri < cells.shape[0]) & (ci >= 0) & (ci < cells.shape[1])
        z = np.maximum(centres[ok, 2] - 0.5 * sizes[ok] + 0.5 * self.tree.resolution, s.floor_band_m)
        np.minimum.at(out, (ri[ok], ci[ok]), z)
        return np.where(cells, out, np.inf)

    def occupied_voxels(self) -> tuple:
        """(centres (n, 3) m, sizes (n,) m) of every occupied leaf: the markers' cubes."""
        return self.tree.occupied_voxels()

    def save(self, path: str | Path) -> None:
        """The tree as an OctoMap .bt file (octovis, octomap_server read it)."""
        self.tree.write_bt(str(path))

    def load(self, path: str | Path) -> None:
        """The tree of a .bt file replaces this one (its resolution too)."""
        self.tree.read_bt(str(path))

    @property
    def memory_bytes(self) -> int:
        return self.tree.memory_bytes

    @property
    def leaf_count(self) -> int:
        return self.tree.leaf_count


def merge_obstacles(occupancy: np.ndarray, layer: np.ndarray) -> np.ndarray:
    """The lidar grid (int8 -1 / 0..100) with the layer's obstacles added: the cell-wise maximum
    (the layer's -1 changes nothing, its OBSTACLE always wins). Same shapes required."""
    if occupancy.shape != layer.shape:
        raise ValueError(f"merge_obstacles: the layer's shape {layer.shape} is not the grid's "
                         f"{occupancy.shape}")
    return np.maximum(occupancy, layer)


def scan_cloud(ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float,
               range_max: float, sensor: np.ndarray) -> np.ndarray:
    """float32 (n, 3) map-frame end points of a laser scan's returns (finite ranges within
    [range_min, range_max]) from ``sensor``, the 4 x 4 pose map ← laser frame: the lidar at its
    mounting height for the OcTree. A beam with no return gives no point: how far it cleared
    is not known (the depth camera's rays clear the space in front of the robot)."""
    r = np.asarray(ranges, np.float64)
    beam = np.arange(r.size)
    ok = np.isfinite(r) & (r >= range_min) & (r <= range_max)
    a = angle_min + angle_increment * beam[ok]
    local = np.stack((r[ok] * np.cos(a), r[ok] * np.sin(a), np.zeros(a.size)), axis=1)
    sensor = np.asarray(sensor, np.float64)
    return (local @ sensor[:3, :3].T + sensor[:3, 3]).astype(np.float32)


def height_colours(z: np.ndarray, z_low: float, z_high: float) -> np.ndarray:
    """float32 (n, 3) RGB in [0, 1] for heights ``z`` m: blue at ``z_low`` through green to red
    at ``z_high`` and above (octomap_server's colouring of occupied cells by height)."""
    t = np.clip((np.asarray(z, np.float64) - z_low) / max(z_high - z_low, 1e-9), 0.0, 1.0)
    rgb = np.stack((np.clip(2.0 * t - 1.0, 0.0, 1.0),          # red rises over the upper half
                    1.0 - np.abs(2.0 * t - 1.0),                 # green peaks in the middle
                    np.clip(1.0 - 2.0 * t, 0.0, 1.0)), axis=1)   # blue falls over the lower half
    return rgb.astype(np.float32)
