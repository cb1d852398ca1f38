"""Mapping: the log-odds occupancy grid (C++ core) with its visit counts and bumper marks, and
the OctoMap layer of 3-D obstacles that joins it (``octomap_layer``)."""
from .._native import OccupancyGrid, ScanStats
from .grid import GridSettings, make_grid
from .octomap_layer import OctomapLayer, OctomapSettings, merge_obstacles

__all__ = ["OccupancyGrid", "ScanStats", "GridSettings", "make_grid", "OctomapLayer", "OctomapSettings",
           "merge_obstacles"]
