"""Metrics of DESIGN §6, computed against the simulator's ground truth (ROS-free)."""
from .metrics import map_precision, map_cells_in_world  # noqa: F401
