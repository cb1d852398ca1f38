"""Exploration: frontier detection and clustering, goal points and information gain."""
from .frontiers import Frontier, FrontierSettings, cluster, detect, find_frontier_cells

__all__ = ["Frontier", "FrontierSettings", "cluster", "detect", "find_frontier_cells"]
