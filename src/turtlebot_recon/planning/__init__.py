"""Global planning: inflated costmap, A* with visit penalty, line-of-sight shortcut, the
state-lattice planner for oriented footprints (``lattice``), and seed 003's RRT, the baseline
(``rrt_seed003``).

The raw native functions are re-exported for callers that need the distance field or the
nearest accessible cell (e.g. frontier goals); ``dijkstra`` (the cost-to-come field) applies
the planner's step cost (PlannerSettings).
"""
from .._native import astar, distance_transform, inflate, nearest_accessible, shortcut
from .costmap import (FREE_SPACE, INSCRIBED, LETHAL, NO_INFORMATION, CostmapSettings,
                      PlannerSettings, PlanningError, dijkstra, make_costmap, plan)
from .lattice import (EscapeArc, LatticePath, LatticeSettings, escape_arcs, footprint_clear,
                      footprint_costmap, lattice_cost_to_come, plan_lattice)
from .rrt_seed003 import RrtSeed003Path, RrtSeed003Settings, plan_rrt_seed003

__all__ = [
    "FREE_SPACE", "INSCRIBED", "LETHAL", "NO_INFORMATION", "CostmapSettings", "PlannerSettings",
    "PlanningError", "make_costmap", "plan", "astar", "dijkstra", "distance_transform", "inflate",
    "nearest_accessible", "shortcut", "LatticePath", "LatticeSettings", "plan_lattice",
    "EscapeArc", "escape_arcs", "footprint_clear", "footprint_costmap", "lattice_cost_to_come",
    "RrtSeed003Path", "RrtSeed003Settings", "plan_rrt_seed003",
]
