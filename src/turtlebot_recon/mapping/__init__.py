"""Mapping: the log-odds occupancy grid (C++ core) with its visit counts and bumper marks."""
from .._native import OccupancyGrid, ScanStats
from .grid import GridSettings, make_grid

__all__ = ["OccupancyGrid", "ScanStats", "GridSettings", "make_grid"]
