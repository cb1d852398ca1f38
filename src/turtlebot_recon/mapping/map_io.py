"""Maps as map_server files: the PGM + YAML pair that map_saver writes and map_server reads.

Occupancy values follow nav_msgs/OccupancyGrid (-1 unknown, 0..100); grids are row-major with
row 0 at the origin (smallest y), while the PGM's first row is the top of the map.
``occupancy_classes`` is the one reading of an image by map_server's rules (the simulator's
worlds use it too: a world is a map_server map plus extras).
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import yaml

from ..config import ConfigError

FREE_PX, OCCUPIED_PX, UNKNOWN_PX = 254, 0, 205
OCCUPIED_THRESH, FREE_THRESH = 65, 25   # map_saver's defaults (ROS values, percent)
# map_server's YAML defaults: a pixel's darkness p in [0, 1] above occupied_thresh is occupied,
# below free_thresh free, unknown between
YAML_OCCUPIED_THRESH, YAML_FREE_THRESH = 0.65, 0.196
MAP_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
# The most cells a map may have to be taken by the explorer and the navigator: 5,000 x 5,000
# cells (250 m x 250 m at 5 cm, 50 times the 1,280 m2 warehouse). A bigger one costs seconds per
# costmap and frontier search and gigabytes, and comes from a wrong resolution or a broken driver.
MAX_MAP_CELLS = 25_000_000


class MapError(ConfigError):
    """A map_server YAML that cannot be read; the message names the file and the key."""


def map_number(meta: dict, key: str, src: Path, default=None) -> float:
    """``meta[key]`` (or ``default``) as a finite float; MapError naming ``src`` and the key."""
    v = meta.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MapError(f"{src}: key '{key}': expected a number, got {v!r}")
    return float(v)


def check_grid(rows: int, cols: int, resolution: float, origin, cells: int, what: str = "map") -> None:
    """ValueError (one line naming ``what`` and the fault) unless a map of ``rows`` x ``cols``
    cells, ``resolution`` m per cell, ``origin`` (x, y) m and ``cells`` data values can be used.
    Takes the header only: a bad map is refused before its data is copied."""
    if rows <= 0 or cols <= 0:
        raise ValueError(f"{what}: empty ({cols} x {rows} cells)")
    if rows * cols > MAX_MAP_CELLS:
        raise ValueError(f"{what}: {cols} x {rows} cells is more than {MAX_MAP_CELLS:,} (at "
                         f"{resolution:g} m per cell; a wrong resolution?)")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"{what}: resolution {resolution!r} m per cell is not positive")
    if not all(math.isfinite(float(o)) for o in origin):
        raise ValueError(f"{what}: origin {tuple(origin)!r} is not finite")
    if cells != rows * cols:
        raise ValueError(f"{what}: {cells} values for {cols} x {rows} cells")


def occupancy_classes(pixels: np.ndarray, meta: dict, src: Path) -> np.ndarray:
    """map_server's interpretation: -1 unknown, 0 free, 100 occupied, per pixel (image order)."""
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapError(f"{src}: key 'mode': expected trinary, scale or raw, got {mode!r}")
    if pixels.ndim == 3:  # map_server averages the colour channels and ignores alpha
        pixels = pixels[..., :3].mean(axis=2)
    v = pixels.astype(np.float64)
    out = np.full(v.shape, -1, np.int8)
    if mode == "raw":
        out[v <= 100] = 0
        out[(v > 0) & (v <= 100)] = 100
        return out
    occ_t = map_number(meta, "occupied_thresh", src, YAML_OCCUPIED_THRESH)
    free_t = map_number(meta, "free_thresh", src, YAML_FREE_THRESH)
    negate = meta.get("negate", 0)
    p = v / 255.0 if negate else (255.0 - v) / 255.0
    out[p > occ_t] = 100
    out[p < free_t] = 0
    return out


def save_map(base: str | Path, occupancy: np.ndarray, resolution: float, origin_xy: tuple,
             origin_yaw: float = 0.0) -> Path:
    """Write ``base``.pgm and ``base``.yaml like map_saver; returns the YAML path."""
    base = Path(base)
    base.parent.mkdir(parents=True, exist_ok=True)
    px = np.full(occupancy.shape, UNKNOWN_PX, np.uint8)
    px[(occupancy >= 0) & (occupancy <= FREE_THRESH)] = FREE_PX
    px[occupancy >= OCCUPIED_THRESH] = OCCUPIED_PX
    pgm = base.with_suffix(".pgm")
    if not cv2.imwrite(str(pgm), np.flipud(px)):
        raise OSError(f"cannot write {pgm}")
    meta = {"image": pgm.name, "resolution": float(resolution),
            "origin": [float(origin_xy[0]), float(origin_xy[1]), float(origin_yaw)],
            "negate": 0, "occupied_thresh": YAML_OCCUPIED_THRESH, "free_thresh": YAML_FREE_THRESH}
    path = base.with_suffix(".yaml")
    path.write_text(yaml.safe_dump(meta, default_flow_style=None, sort_keys=False))
    return path


def load_map(path: str | Path) -> tuple:
    """(occupancy int8 with -1/0/100, resolution, (origin_x, origin_y)) of a map_server YAML."""
    path = Path(path)
    meta = yaml.safe_load(path.read_text())
    if not isinstance(meta, dict):
        raise MapError(f"{path}: expected a mapping at the top level, got {meta!r}")
    for key in ("image", "resolution"):
        if key not in meta:
            raise MapError(f"{path}: key '{key}': missing")
    resolution = map_number(meta, "resolution", path)
    if resolution <= 0:
        raise MapError(f"{path}: key 'resolution': must be positive, got {resolution:g}")
    pixels = cv2.imread(str(path.parent / str(meta["image"])), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise OSError(f"{path}: cannot read image {meta['image']}")
    occ = np.flipud(occupancy_classes(pixels, meta, path)).copy()
    origin = meta.get("origin", [0.0, 0.0, 0.0])
    return occ, resolution, (float(origin[0]), float(origin[1]))


def load_map_as(path: str | Path, what: str) -> tuple:
    """``load_map``, with every way the file can fail (missing, not YAML, no image, a bad key) as
    one ValueError: "cannot load WHAT 'PATH': why" (a node's parameter, a command's argument)."""
    try:
        return load_map(path)
    except (OSError, KeyError, TypeError, ValueError, AttributeError, yaml.YAMLError) as exc:
        why = " ".join(str(exc).split())          # one line: YAML's errors span several
        raise ValueError(f"cannot load {what} {str(path)!r}: {why}") from None
