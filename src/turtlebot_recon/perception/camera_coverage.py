"""Camera coverage: which walls the camera has seen well enough to read a tag on them.

Seed 000 keeps "a second map of what the camera has seen" next to the lidar map; here it is a
uint8 mask over the lidar map's cells, 1 on the wall cells that some camera frame saw within
a readable range and at a readable angle (``_native.camera_coverage``, rules in
include/turtlebot_recon/camera_coverage.hpp). ``CameraCoverage`` keeps that mask across map
updates: the mapper's grid grows by whole cells and its origin moves, so the mask is re-indexed
into each new grid by the origin's offset.

Grids are nav_msgs/OccupancyGrid data as numpy: int8 (rows, cols), -1 unknown, 0..100, row 0
at the smallest y; ``origin`` is the (x, y) m of cell (0, 0)'s corner in the map frame.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from numbers import Real
from typing import Optional, Tuple

import numpy as np
from scipy import ndimage

from .. import _native
from ..config import positive, require
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import CameraSpec

log = logging.getLogger(__name__)

# to_occupancy_grid_data's values, chosen for rviz's Map display. With the "costmap" colour
# scheme 0 is transparent (the /map shows through), 20 blue and 100 magenta; with the "map"
# scheme 0 is white, 20 light grey and 100 black.
NOT_WALL = 0
WALL_UNSEEN = 20
WALL_SEEN = 100

# Origins that differ by less than this many cells count as the same cell edges.
_ALIGN_TOLERANCE_CELLS = 1e-3
_FOUR_NEIGHBOURS = ndimage.generate_binary_structure(2, 1)


@dataclass(frozen=True)
class CoverageSettings:
    max_incidence_rad: float = math.radians(60.0)  # rad, most oblique view of a wall that counts
                                                   # (between the line of sight and the normal)
    min_tag_px: float = 20.0        # px, smallest tag side in the image the detector reads reliably
    tag_size_m: float = 0.10        # m, side of the smallest tags' black square (the ArUco's)
    rays: int = 0                   # rays over the field of view; 0: enough to leave no gaps
                                    # on walls within range and incidence (camera_coverage.hpp)

    def __post_init__(self):
        self.validate("CoverageSettings")

    def validate(self, src: str) -> None:
        positive(src, self, "min_tag_px", "tag_size_m")
        require(isinstance(self.max_incidence_rad, Real)
                and 0.0 <= self.max_incidence_rad <= math.pi / 2, src, "max_incidence_rad",
                f"must be in [0, pi/2] rad, got {self.max_incidence_rad!r}")
        require(isinstance(self.rays, int) and self.rays >= 0, src, "rays",
                f"must be an integer >= 0 (0: automatic), got {self.rays!r}")


class CameraCoverage:
    """The seen mask of one camera, kept across map updates.

    fx_px: the camera's focal length in pixels; hfov_rad: its horizontal field of view. A tag
    of side ``tag_size_m`` at distance d spans ``fx_px * tag_size_m / d`` pixels, so it is
    readable up to ``max_range_m = tag_size_m * fx_px / min_tag_px`` (waffle_pi: 0.16 m *
    530 px / 20 px = 4.2 m).
    """

    def __init__(self, fx_px: float, hfov_rad: float,
                 settings: CoverageSettings = CoverageSettings()):
        if not (isinstance(fx_px, Real) and math.isfinite(fx_px) and fx_px > 0):
            raise ValueError(f"fx_px must be a positive number of pixels, got {fx_px!r}")
        if not (isinstance(hfov_rad, Real) and 0.0 < hfov_rad <= math.pi):
            raise ValueError(f"hfov_rad must be in (0, pi], got {hfov_rad!r}")
        self.fx_px = float(fx_px)
        self.hfov_rad = float(hfov_rad)
        self.settings = settings
        self._seen: Optional[np.ndarray] = None        # uint8, aligned with the last map
        self._walls: Optional[np.ndarray] = None       # bool, the last map's wall cells
        self._resolution: Optional[float] = None
        self._origin: Optional[Tuple[float, float]] = None

    @classmethod
    def for_camera(cls, camera: CameraSpec,
                   settings: CoverageSettings = CoverageSettings()) -> "CameraCoverage":
        return cls(camera.fx_px, camera.hfov_rad, settings)

    @property
    def max_range_m(self) -> float:
        """Farthest wall at which a tag still spans ``min_tag_px`` pixels (m)."""
        return self.settings.tag_size_m * self.fx_px / self.settings.min_tag_px

    @property
    def seen(self) -> Optional[np.ndarray]:
        """uint8 (rows, cols) aligned with the last map given to ``update``, 1 = wall seen;
        None before the first update."""
        return self._seen

    def reset(self) -> None:
        """Forget everything seen."""
        self._seen = self._walls = self._resolution = self._origin = None

    def update(self, occupancy: np.ndarray, resolution: float, origin: Tuple[float, float],
               camera_pose_xyyaw: Tuple[float, float, float]) -> np.ndarray:
        """Add what the camera at ``camera_pose_xyyaw`` (x m, y m, yaw rad, map frame) sees in
        ``occupancy`` to the mask, first re-indexing the mask into this map's grid. Returns the
        mask (``seen``)."""
        occupancy = np.asarray(occupancy)
        if occupancy.ndim != 2:
            raise ValueError(f"occupancy must be a 2-D (rows, cols) array, got {occupancy.ndim}-D")
        if occupancy.dtype != np.int8:
            raise ValueError(f"occupancy must have dtype int8 (ROS values), got {occupancy.dtype}")
        if not (isinstance(resolution, Real) and math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {resolution!r}")
        seen = self._realigned(occupancy.shape, float(resolution), tuple(map(float, origin)))
        self._seen = _native.camera_coverage(
            occupancy, resolution, origin, camera_pose_xyyaw, hfov_rad=self.hfov_rad,
            max_range_m=self.max_range_m, max_incidence_rad=self.settings.max_incidence_rad,
            occupied_threshold=OCCUPIED_THRESH, rays=self.settings.rays,
            seen=seen)
        self._walls = occupancy >= OCCUPIED_THRESH
        self._resolution, self._origin = float(resolution), tuple(map(float, origin))
        return self._seen

    def wall_cells(self, occupancy: np.ndarray, reachable_free_mask: np.ndarray) -> np.ndarray:
        """bool (rows, cols): the wall cells (occupancy >= OCCUPIED_THRESH) that share a
        side with a reachable free cell: the wall faces the robot could look at.

        A side, not a corner: a wall cell whose only free neighbour is diagonal (the inner
        corner of a room) is a point of the wall's surface, not a face a tag could hang on,
        and no ray reaches it first (rays walk 4-connected, so they hit one of its two wall
        neighbours before it): counting it would keep ``seen_share`` below 1 in every room.
        """
        occupancy, free = self._check_pair(occupancy, reachable_free_mask)
        walls = occupancy >= OCCUPIED_THRESH
        return walls & ndimage.binary_dilation(free, structure=_FOUR_NEIGHBOURS)

    def seen_share(self, occupancy: np.ndarray, reachable_free_mask: np.ndarray) -> float:
        """Seen wall cells / wall cells (``wall_cells``) in the last map; 1.0 with no wall."""
        walls = self.wall_cells(occupancy, reachable_free_mask)
        total = int(np.count_nonzero(walls))
        if total == 0:
            return 1.0
        seen = self._seen_for(walls.shape)
        return int(np.count_nonzero(walls & seen)) / total

    def to_occupancy_grid_data(self,
                               reachable_free_mask: Optional[np.ndarray] = None) -> np.ndarray:
        """int8 (rows, cols) for a nav_msgs/OccupancyGrid (/camera_coverage) with the last map's
        geometry: WALL_SEEN (100) on seen walls, WALL_UNSEEN (20) on walls not seen yet,
        NOT_WALL (0) elsewhere (transparent in rviz's "costmap" colour scheme). The walls are
        those of the last map, or with ``reachable_free_mask`` its ``wall_cells`` (then the
        back faces and insides of thick walls stay 0 instead of showing as unseen)."""
        if self._walls is None:
            raise ValueError("to_occupancy_grid_data: no map yet (call update first)")
        walls = self._walls
        if reachable_free_mask is not None:
            walls = walls & ndimage.binary_dilation(
                self._check_mask(reachable_free_mask, walls.shape), structure=_FOUR_NEIGHBOURS)
        out = np.full(walls.shape, NOT_WALL, np.int8)
        out[walls] = WALL_UNSEEN
        out[walls & (self._seen != 0)] = WALL_SEEN
        return out

    # ---------------------------------------------------------------------------- internals

    def _realigned(self, shape, resolution: float, origin) -> Optional[np.ndarray]:
        """The mask moved into a grid of ``shape`` at ``origin``; None when there is nothing to
        keep (first map, or a grid whose cell edges differ: then a warning)."""
        if self._seen is None:
            return None
        if (self._seen.shape == tuple(shape) and self._origin == origin
                and self._resolution == resolution):
            return self._seen                          # the same grid: add to it in place
        if not math.isclose(resolution, self._resolution, rel_tol=1e-9):
            log.warning("camera coverage reset: the map's resolution changed from %g to %g m",
                        self._resolution, resolution)
            return None
        # Offset of the old grid's cell (0, 0) in the new grid, in cells.
        shift = ((self._origin[1] - origin[1]) / resolution,
                 (self._origin[0] - origin[0]) / resolution)
        d_row, d_col = (int(round(v)) for v in shift)
        if max(abs(shift[0] - d_row), abs(shift[1] - d_col)) > _ALIGN_TOLERANCE_CELLS:
            log.warning("camera coverage reset: the map's origin moved by a fraction of a cell "
                        "(%.3f, %.3f cells)", shift[1], shift[0])
            return None
        old = self._seen
        out = np.zeros(shape, np.uint8)
        # Overlap of old rows [0, R) moved to [d_row, d_row + R) with new rows [0, rows).
        r0, r1 = max(d_row, 0), min(d_row + old.shape[0], shape[0])
        c0, c1 = max(d_col, 0), min(d_col + old.shape[1], shape[1])
        if r0 < r1 and c0 < c1:
            out[r0:r1, c0:c1] = old[r0 - d_row:r1 - d_row, c0 - d_col:c1 - d_col]
        return out

    def _seen_for(self, shape) -> np.ndarray:
        if self._seen is None:
            return np.zeros(shape, bool)
        if self._seen.shape != tuple(shape):
            raise ValueError(f"occupancy has shape {tuple(shape)}, the last map given to update "
                             f"{self._seen.shape}")
        return self._seen != 0

    def _check_pair(self, occupancy, reachable_free_mask):
        occupancy = np.asarray(occupancy)
        if occupancy.ndim != 2:
            raise ValueError(f"occupancy must be a 2-D (rows, cols) array, got {occupancy.ndim}-D")
        return occupancy, self._check_mask(reachable_free_mask, occupancy.shape)

    @staticmethod
    def _check_mask(mask, shape) -> np.ndarray:
        mask = np.asarray(mask)
        if mask.shape != tuple(shape):
            raise ValueError(f"reachable_free_mask has shape {mask.shape}, the map {tuple(shape)}")
        return mask.astype(bool, copy=False)
