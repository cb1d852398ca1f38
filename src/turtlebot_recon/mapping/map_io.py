"""Maps as map_server files: the PGM + YAML pair that map_saver writes and map_server reads.

Occupancy values follow nav_msgs/OccupancyGrid (-1 unknown, 0..100); grids are row-major with
row 0 at the origin (smallest y), while the PGM's first row is the top of the map.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import yaml

FREE_PX, OCCUPIED_PX, UNKNOWN_PX = 254, 0, 205
OCCUPIED_THRESH, FREE_THRESH = 65, 25   # map_saver's defaults (ROS values, percent)


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
            "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
    path = base.with_suffix(".yaml")
    path.write_text(yaml.safe_dump(meta, default_flow_style=None, sort_keys=False))
    return path


def load_map(path: str | Path) -> tuple:
    """(occupancy int8 with -1/0/100, resolution, (origin_x, origin_y)) of a map_server YAML."""
    from ..sim.world import occupancy_classes   # one reading of map_server's thresholds
    path = Path(path)
    meta = yaml.safe_load(path.read_text())
    pixels = cv2.imread(str(path.parent / meta["image"]), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise OSError(f"{path}: cannot read image {meta['image']}")
    occ = np.flipud(occupancy_classes(pixels, meta, path)).copy()
    origin = meta.get("origin", [0.0, 0.0, 0.0])
    return occ, float(meta["resolution"]), (float(origin[0]), float(origin[1]))
