"""Metrics of DESIGN §6, computed against the simulator's ground truth (ROS-free)."""
from .metrics import distance_until, map_precision, map_cells_in_world  # noqa: F401
from .coverage import CoverageTracker, reachable_cells, reachable_free_space, world_to_map  # noqa: F401
from .report import plot_coverage, plot_map, write_report  # noqa: F401
