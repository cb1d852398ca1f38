"""Settings and factory for the C++ log-odds occupancy grid (``_native.OccupancyGrid``).

Field names match the grid's constructor arguments (and ``grid:`` in config/mapper.yaml), so
``make_grid`` passes them straight through; lengths in metres, probabilities in (0, 1).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .. import _native
from ..config import positive, require


@dataclass(frozen=True)
class GridSettings:
    resolution: float = 0.05            # m per cell
    width_m: float = 10.0               # initial extent along x; the grid grows as needed
    height_m: float = 10.0              # initial extent along y
    origin_x: float = -5.0              # m, initial lower-left corner in the map frame
    origin_y: float = -5.0              # m
    p_hit: float = 0.7                  # occupancy probability one hit votes for, in (0.5, 1)
    p_miss: float = 0.4                 # occupancy probability one miss votes for, in (0, 0.5)
    p_min: float = 0.12                 # clamp: a cell never gets surer than this of free ...
    p_max: float = 0.97                 # ... nor of occupied, so the map can change its mind
    grow_margin_m: float = 2.0          # extra room added on each side a scan leaves the grid
    no_return_clear_m: float = 3.5      # clear this far along beams with no return (0 = don't)
    range_cap_m: float = 0.0            # returns beyond this only clear up to it (seed 001: 2.0; 0 = no cap)
    visit_min_speed_mps: float = 0.05   # the visit map counts a cell only above this speed
    bumper_cells: int = 5               # cells marked occupied per bumper press (seed 001)

    def validate(self, src: str) -> None:
        positive(src, self, "resolution", "width_m", "height_m", "bumper_cells")
        require(math.isfinite(self.origin_x) and math.isfinite(self.origin_y), src, "origin_x",
                "origin_x and origin_y must be finite")
        require(0.5 < self.p_hit < 1.0, src, "p_hit", f"must be in (0.5, 1), got {self.p_hit}")
        require(0.0 < self.p_miss < 0.5, src, "p_miss", f"must be in (0, 0.5), got {self.p_miss}")
        require(0.0 < self.p_min < self.p_max < 1.0, src, "p_min",
                f"need 0 < p_min < p_max < 1, got p_min={self.p_min}, p_max={self.p_max}")
        for key in ("grow_margin_m", "no_return_clear_m", "range_cap_m", "visit_min_speed_mps"):
            value = getattr(self, key)
            require(math.isfinite(value) and value >= 0.0, src, key, f"must be >= 0, got {value!r}")


# The constructor's arguments; the other fields are per-call arguments used by the mapper.
_GRID_ARGS = ("resolution", "width_m", "height_m", "origin_x", "origin_y", "p_hit", "p_miss",
              "p_min", "p_max", "grow_margin_m")


def make_grid(settings: GridSettings) -> _native.OccupancyGrid:
    """An empty (all unknown) grid built from ``settings``."""
    values = dataclasses.asdict(settings)
    return _native.OccupancyGrid(**{k: values[k] for k in _GRID_ARGS})
