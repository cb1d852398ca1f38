"""Simulator worlds (DESIGN §4): a map_server map plus optional start, wall height, tags and
obstacles with a height band (boxes solid only between two heights: a step, a bed frame).

Grids here follow nav_msgs/OccupancyGrid order: row 0 is the bottom of the image (smallest y),
cell (i, j) has its centre at ``origin + ((j + 0.5) * res, (i + 0.5) * res)``. Every pixel that
is not free (occupied or unknown) is solid, so any saved map of any building is a world.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage

from ..config import load_yaml, ConfigError
from ..geometry import cell_to_xy, inside, xy_to_cell
from ..perception.families import canonical, marker_count, marker_set
from ..mapping.map_io import MAP_KEYS, MapError, map_number, occupancy_classes
from ..paths import SHARE_DIR

log = logging.getLogger(__name__)

WORLDS_DIR = SHARE_DIR / "worlds"
EXTRA_KEYS = {"start", "wall_height", "tags", "obstacles"}
TAG_KEYS = {"id", "family", "x", "y", "z", "yaw", "size"}
OBSTACLE_KEYS = ("x0", "y0", "x1", "y1", "z_min", "z_max")   # all required, in metres
START_CLEARANCE_M = 0.35   # an automatic start leaves this much room around the robot centre


class WorldError(ConfigError):
    """A world file that cannot be simulated; the message names the file and the key."""


@dataclass(frozen=True)
class Tag:
    id: int
    family: str
    x: float      # m, centre of the marker on the wall surface (world frame)
    y: float
    z: float      # m, height of the marker centre
    yaw: float    # rad, direction of the marker's outward normal
    size: float   # m, edge of the black square

    def matrix(self) -> np.ndarray:
        """4x4 pose of the marker frame in the world (perception.detection's convention: z its
        outward normal, y up, x to the right of someone reading it)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        T = np.eye(4)
        T[:3, :3] = np.array([[-s, 0.0, c], [c, 0.0, s], [0.0, 1.0, 0.0]])
        T[:3, 3] = (self.x, self.y, self.z)
        return T


@dataclass(frozen=True)
class Obstacle:
    """A box over the footprint [x0, x1] x [y0, y1] (world frame, m, axis-aligned), solid only
    between the heights z_min and z_max (m above the floor): a 0.15 m step is (0, 0.15), a bed
    frame a lidar passes beneath (0.30, 0.50)."""
    x0: float
    y0: float
    x1: float
    y1: float
    z_min: float
    z_max: float


@dataclass(frozen=True)
class World:
    name: str
    path: Path
    resolution: float          # m per cell
    origin: tuple              # (x, y) of the grid's lower-left corner, m
    free: np.ndarray           # bool (rows, cols), True where the robot may be
    wall_height: float         # m
    start: tuple               # (x, y, yaw)
    tags: tuple                # Tag, ...
    obstacles: tuple = ()      # Obstacle, ...: their footprints are not free (F, the metrics)
    wall_free: np.ndarray | None = None   # the image's free cells, before the obstacles'
                                          # footprints (None: the same as ``free``)

    @property
    def solid(self) -> np.ndarray:
        return ~self.free

    @property
    def walls(self) -> np.ndarray:
        """The cells that are solid from the floor to wall_height: the image's walls, without
        the obstacles' footprints (the simulator builds those at their own heights)."""
        return ~(self.free if self.wall_free is None else self.wall_free)

    @property
    def size_m(self) -> tuple:
        return (self.free.shape[1] * self.resolution, self.free.shape[0] * self.resolution)

    def cell(self, x: float, y: float) -> tuple:
        """(row, col) of the cell holding world point (x, y); may be outside the grid."""
        return xy_to_cell((x, y), self.resolution, self.origin)

    def is_free(self, x: float, y: float) -> bool:
        r, c = self.cell(x, y)
        return inside(r, c, self.free.shape) and bool(self.free[r, c])

    def occupancy(self) -> np.ndarray:
        """The world as a map: int8, 0 where free, 100 where solid (no unknown cells)."""
        return np.where(self.free, 0, 100).astype(np.int8)

    def clearance(self) -> np.ndarray:
        """Distance (m) from each free cell centre to the nearest solid cell's edge; 0 on solid."""
        padded = np.pad(self.free, 1, constant_values=False)   # outside the image is solid
        d = ndimage.distance_transform_edt(padded)[1:-1, 1:-1] * self.resolution
        return np.where(self.free, np.maximum(d - 0.5 * self.resolution, 0.0), 0.0)


def world_path(name_or_path: str | Path) -> Path:
    """A world by its name in worlds/ or by a path to any world (map_server) YAML."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return p
    return WORLDS_DIR / f"{name_or_path}.yaml"


def load_world(name_or_path: str | Path) -> World:
    """Load and check a world; raise WorldError naming the file and key on bad input."""
    try:
        return _load_world(world_path(name_or_path))
    except MapError as exc:     # the map_server part of the file (mapping.map_io's reading)
        raise WorldError(str(exc)) from None


def _load_world(src: Path) -> World:
    if not src.exists():
        known = sorted(q.stem for q in WORLDS_DIR.glob("*.yaml"))
        raise WorldError(f"{src}: world file not found (shipped worlds: {known})")
    try:
        meta = load_yaml(src)
    except ConfigError as exc:
        raise WorldError(str(exc)) from None
    unknown = sorted(set(meta) - MAP_KEYS - EXTRA_KEYS)
    if unknown:
        log.warning("%s: ignoring unknown key(s) %s", src, unknown)
    if "image" not in meta:
        raise WorldError(f"{src}: key 'image': missing")
    image = src.parent / str(meta["image"])
    if not image.is_file():
        raise WorldError(f"{src}: key 'image': file {image} not found")
    res = map_number(meta, "resolution", src)
    if not 0.001 <= res <= 1.0:
        raise WorldError(f"{src}: key 'resolution': {res} m per pixel is not a plausible map "
                         "resolution (expected 0.001-1.0)")
    origin = meta.get("origin", [0.0, 0.0, 0.0])
    if not (isinstance(origin, list) and len(origin) in (2, 3)
            and all(isinstance(o, (int, float)) and math.isfinite(o) for o in origin)):
        raise WorldError(f"{src}: key 'origin': expected [x, y, yaw], got {origin!r}")
    if len(origin) == 3 and abs(origin[2]) > 1e-9:
        raise WorldError(f"{src}: key 'origin': a rotated map (yaw {origin[2]}) is not supported")
    pixels = cv2.imread(str(image), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise WorldError(f"{src}: key 'image': {image} is not a readable image")
    free = np.flipud(occupancy_classes(pixels, meta, src) == 0).copy()
    wall_height = map_number(meta, "wall_height", src, 0.5)
    if wall_height <= 0:
        raise WorldError(f"{src}: key 'wall_height': must be positive, got {wall_height}")
    world = World(name=src.stem, path=src, resolution=res, origin=(float(origin[0]), float(origin[1])),
                  free=free, wall_height=wall_height, start=(0.0, 0.0, 0.0), tags=())
    raw = meta.get("obstacles") or []
    if not isinstance(raw, list):
        raise WorldError(f"{src}: key 'obstacles': expected a list of boxes, got {raw!r}")
    obstacles = tuple(_obstacle(world, i, o, src) for i, o in enumerate(raw))
    if obstacles:
        world = World(**{**world.__dict__, "free": free & ~footprint_mask(world, obstacles),
                         "obstacles": obstacles, "wall_free": free})
    start = _start(world, meta.get("start"), src)
    tags = tuple(_tag(world, i, t, src) for i, t in enumerate(meta.get("tags") or []))
    ids = [(marker_set(t.family), t.id) for t in tags]
    if len(set(ids)) != len(ids):
        raise WorldError(f"{src}: key 'tags': duplicate (family, id) pairs")
    return World(**{**world.__dict__, "start": start, "tags": tags})


def _start(world: World, start, src: Path) -> tuple:
    if start is not None:
        if not (isinstance(start, list) and len(start) == 3
                and all(isinstance(s, (int, float)) and math.isfinite(s) for s in start)):
            raise WorldError(f"{src}: key 'start': expected [x, y, yaw], got {start!r}")
        if not world.is_free(start[0], start[1]):
            raise WorldError(f"{src}: key 'start': ({start[0]}, {start[1]}) is not in free space")
        return (float(start[0]), float(start[1]), float(start[2]))
    return auto_start(world, src)


def auto_start(world: World, src: Path, clearance_m: float = START_CLEARANCE_M) -> tuple:
    """A free cell with room for the robot, in the largest open region, nearest the map centre."""
    room = world.clearance() >= clearance_m
    if not room.any():
        raise WorldError(f"{src}: key 'image': no free cell has {clearance_m} m of clearance "
                         "for the robot (is the map all occupied/unknown, or negated?)")
    labels, n = ndimage.label(room, structure=np.ones((3, 3)))
    sizes = ndimage.sum(room, labels, index=np.arange(1, n + 1))
    biggest = labels == (1 + int(np.argmax(sizes)))
    rows, cols = np.nonzero(biggest)
    centre = (np.array(world.free.shape) - 1) / 2.0
    k = int(np.argmin((rows - centre[0]) ** 2 + (cols - centre[1]) ** 2))
    return (*cell_to_xy((rows[k], cols[k]), world.resolution, world.origin), 0.0)


def _tag(world: World, i: int, t, src: Path) -> Tag:
    where = f"{src}: key 'tags[{i}]'"
    if not isinstance(t, dict):
        raise WorldError(f"{where}: expected a mapping, got {t!r}")
    missing = sorted(TAG_KEYS - {"family", "z", "size"} - set(t))
    if missing:
        raise WorldError(f"{where}: missing {missing}")
    unknown = sorted(set(t) - TAG_KEYS)
    if unknown:
        raise WorldError(f"{where}: unknown key(s) {unknown}")
    try:
        family = canonical(t.get("family", "tag36h11"))
    except ValueError as exc:
        raise WorldError(f"{where}: {exc}") from None
    if not 0 <= int(t["id"]) < marker_count(family):
        raise WorldError(f"{where}: id {t['id']} is not in family {family} "
                         f"(0..{marker_count(family) - 1})")
    tag = Tag(id=int(t["id"]), family=family, x=float(t["x"]),
              y=float(t["y"]), z=float(t.get("z", 0.25)), yaw=float(t["yaw"]),
              size=float(t.get("size", 0.16)))
    if not 0.0 < tag.size <= 2.0:
        raise WorldError(f"{where}: size {tag.size} m is not a plausible marker size")
    probe = max(world.resolution, 0.05)
    nx, ny = math.cos(tag.yaw), math.sin(tag.yaw)
    if not world.is_free(tag.x + probe * nx, tag.y + probe * ny):
        raise WorldError(f"{where}: tag {tag.id} at ({tag.x}, {tag.y}) is inside solid space "
                         f"(the point {probe} m along its normal, yaw {tag.yaw}, is not free)")
    if world.is_free(tag.x - probe * nx, tag.y - probe * ny):
        log.warning("%s: tag %d at (%.2f, %.2f) is not on a wall (free space behind it)",
                    where, tag.id, tag.x, tag.y)
    if not 0.0 < tag.z + 0.5 * tag.size <= world.wall_height + 1e-9:
        raise WorldError(f"{where}: tag {tag.id} (z {tag.z}, size {tag.size}) does not fit on a "
                         f"wall of height {world.wall_height} m")
    out = _clear_of_wall(world, tag)
    if out > 0.0:
        log.info("%s: tag %d hangs at %.0f deg to the map's pixel walls: moved %.3f m off the wall "
                 "so that all of it is in front of them", where, tag.id,
                 math.degrees(math.remainder(tag.yaw, math.pi / 2)), out)
        tag = Tag(tag.id, tag.family, tag.x + out * nx, tag.y + out * ny, tag.z, tag.yaw, tag.size)
    return tag


def _obstacle(world: World, i: int, o, src: Path) -> Obstacle:
    where = f"{src}: key 'obstacles[{i}]'"
    if not isinstance(o, dict):
        raise WorldError(f"{where}: expected a mapping with {list(OBSTACLE_KEYS)}, got {o!r}")
    missing = [k for k in OBSTACLE_KEYS if k not in o]
    if missing:
        raise WorldError(f"{where}: missing {missing}")
    unknown = sorted(set(o) - set(OBSTACLE_KEYS))
    if unknown:
        raise WorldError(f"{where}: unknown key(s) {unknown} (known: {list(OBSTACLE_KEYS)})")
    for k in OBSTACLE_KEYS:
        v = o[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise WorldError(f"{where}: '{k}' must be a finite number (m), got {v!r}")
    box = Obstacle(**{k: float(o[k]) for k in OBSTACLE_KEYS})
    if not (box.x0 < box.x1 and box.y0 < box.y1):
        raise WorldError(f"{where}: the footprint needs x0 < x1 and y0 < y1 (m), got "
                         f"({box.x0}, {box.y0})-({box.x1}, {box.y1})")
    if box.z_min < 0.0:
        raise WorldError(f"{where}: z_min {box.z_min} m is below the floor (must be >= 0)")
    if box.z_min >= box.z_max:
        raise WorldError(f"{where}: z_min {box.z_min} m must be below z_max {box.z_max} m")
    (x_lo, y_lo), (sx, sy) = world.origin, world.size_m
    if box.x1 <= x_lo or box.y1 <= y_lo or box.x0 >= x_lo + sx or box.y0 >= y_lo + sy:
        raise WorldError(f"{where}: ({box.x0}, {box.y0})-({box.x1}, {box.y1}) lies outside the map "
                         f"({x_lo}, {y_lo})-({x_lo + sx}, {y_lo + sy})")
    return box


def footprint_mask(world: World, boxes) -> np.ndarray:
    """bool grid of ``world``'s shape: True on every cell that a box's footprint overlaps
    (a cell partly under a box is not free: the clearance and F stay conservative)."""
    mask = np.zeros(world.free.shape, bool)
    rows, cols = mask.shape
    for b in boxes:
        r0, c0 = world.cell(b.x0, b.y0)
        r1, c1 = world.cell(b.x1 - 1e-9, b.y1 - 1e-9)
        mask[max(r0, 0):max(min(r1 + 1, rows), 0), max(c0, 0):max(min(c1 + 1, cols), 0)] = True
    return mask


def _clear_of_wall(world: World, tag: Tag, step_m: float = 0.002, most_m: float = 0.1) -> float:
    """How far (m) the marker must move along its normal for its whole width (quiet zone
    included) to lie in free cells. Walls are drawn as the map's solid pixels, whose faces are
    axis-aligned: a marker at an angle to them (a real map's wall) would sink into them at one
    side, and the camera would see half of it. 0 for a marker on a straight face."""
    from .markers import full_scale
    half = 0.5 * tag.size * full_scale(tag.family)
    nx, ny = math.cos(tag.yaw), math.sin(tag.yaw)
    along = np.linspace(-half, half, 21)
    px, py = tag.x - along * ny, tag.y + along * nx          # the marker's bottom edge, seen from above
    for k in range(int(most_m / step_m) + 1):
        d = k * step_m + 0.001
        if all(world.is_free(x + d * nx, y + d * ny) for x, y in zip(px, py)):
            return k * step_m
    return 0.0
