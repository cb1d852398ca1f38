"""Order frontier goals as an open tour from the robot: nearest insertion, then 2-opt.

The robot visits every goal once and does not come back (an open path with a fixed start),
so the tour is a Hamiltonian path from node 0. Two constructions are improved by 2-opt,
nearest insertion (Rosenkrantz, Stearns & Lewis 1977) and nearest neighbour, and the shorter
is returned, so the result is never longer than the nearest-neighbour path.

Distances come as a matrix ``D`` of shape (n + 1, n + 1): row and column 0 are the start,
1..n the points; ``D[i, j]`` is the cost of going i -> j. Only row 0 is read for the start
(nothing returns to it), so the first leg may carry robot-specific terms (heading, gain)
that the legs between goals do not. Between goals the matrix is taken as symmetric
(2-opt reverses segments): ``order`` averages D[1:, 1:] with its transpose. Non-finite
entries (no path) become ``UNREACHABLE_M``, so they are used last and arithmetic stays
finite. Sizes up to ~60 points: every step is an O(n^2) numpy array operation.
"""
from __future__ import annotations

import math
from typing import Callable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..planning import NO_INFORMATION, dijkstra

Point = Tuple[float, float]
Cell = Tuple[int, int]
DistanceArg = Union[None, np.ndarray, Callable[[Point, Point], float]]

UNREACHABLE_M = 1.0e6   # stands for "no path" between two goals: larger than any real tour
_EPS = 1e-9             # a 2-opt move must shorten the tour by more than this (m)


def order(start_xy: Point, points: Sequence[Point], dist: DistanceArg = None) -> List[int]:
    """Visiting order of ``points`` (indices into it) on an open tour from ``start_xy``.

    dist: None (Euclidean), a callable ``dist(a_xy, b_xy) -> float``, or an (n + 1, n + 1)
    matrix with the start at index 0 (see the module docstring).
    """
    n = len(points)
    if n == 0:
        return []
    D = prepare(distance_matrix(start_xy, points, dist))
    best = solve(D)
    return [i - 1 for i in best[1:]]


def distance_matrix(start_xy: Point, points: Sequence[Point],
                    dist: DistanceArg = None) -> np.ndarray:
    """The (n + 1, n + 1) matrix of ``dist`` over [start] + points (float64)."""
    n = len(points)
    if isinstance(dist, np.ndarray) or (dist is not None and not callable(dist)):
        D = np.asarray(dist, dtype=float)
        if D.shape != (n + 1, n + 1):
            raise ValueError(f"order: distance matrix must be ({n + 1}, {n + 1}) with the start "
                             f"at index 0, got {D.shape}")
        return D.copy()
    nodes = np.array([tuple(start_xy)] + [tuple(p) for p in points], dtype=float)
    if dist is None:
        diff = nodes[:, None, :] - nodes[None, :, :]
        return np.hypot(diff[..., 0], diff[..., 1])
    return np.array([[0.0 if i == j else float(dist(tuple(a), tuple(b)))
                      for j, b in enumerate(nodes)] for i, a in enumerate(nodes)])


def prepare(D: np.ndarray) -> np.ndarray:
    """Finite copy of D with the goal-to-goal block made symmetric (see module docstring)."""
    D = np.where(np.isfinite(D), D, UNREACHABLE_M).astype(float)
    D[1:, 1:] = 0.5 * (D[1:, 1:] + D[1:, 1:].T)
    np.fill_diagonal(D, 0.0)
    return D


def solve(D: np.ndarray) -> List[int]:
    """Open tour over all nodes of a prepared matrix, starting at node 0: [0, ...]."""
    candidates = [two_opt(D, nearest_insertion(D)), two_opt(D, nearest_neighbour(D))]
    return min(candidates, key=lambda tour: length(D, tour))


def length(D: np.ndarray, tour: Sequence[int]) -> float:
    """Cost of visiting ``tour`` in order (no return leg)."""
    t = np.asarray(tour, dtype=int)
    return float(D[t[:-1], t[1:]].sum()) if len(t) > 1 else 0.0


def nearest_neighbour(D: np.ndarray) -> List[int]:
    """Greedy path: from the last node, go to the closest unvisited one."""
    n = len(D)
    tour, free = [0], np.ones(n, dtype=bool)
    free[0] = False
    for _ in range(n - 1):
        row = np.where(free, D[tour[-1]], np.inf)
        nxt = int(np.argmin(row))
        tour.append(nxt)
        free[nxt] = False
    return tour


def nearest_insertion(D: np.ndarray) -> List[int]:
    """Nearest insertion for an open path from node 0.

    Select the unvisited node nearest to any node on the path, insert it where it adds the
    least: between two consecutive nodes (D[a, k] + D[k, b] - D[a, b]) or after the last
    one (D[last, k]); never before the start.
    """
    n = len(D)
    tour = [0]
    free = np.ones(n, dtype=bool)
    free[0] = False
    nearest = D[0].copy()                  # distance from the path to each node
    for _ in range(n - 1):
        k = int(np.argmin(np.where(free, nearest, np.inf)))
        t = np.asarray(tour)
        gaps = D[t[:-1], k] + D[k, t[1:]] - D[t[:-1], t[1:]]   # insert between t[i], t[i+1]
        costs = np.append(gaps, D[t[-1], k])                     # ... or append at the end
        pos = int(np.argmin(costs)) + 1
        tour.insert(pos, k)
        free[k] = False
        nearest = np.minimum(nearest, D[k])
    return tour


def two_opt(D: np.ndarray, tour: Sequence[int], max_moves: Optional[int] = None) -> List[int]:
    """Best-improvement 2-opt on an open path with a fixed first node.

    Reversing tour[i..j] (1 <= i < j) replaces edges (tour[i-1], tour[i]) and (tour[j],
    tour[j+1]) by (tour[i-1], tour[j]) and (tour[i], tour[j+1]); when j is the last node the
    second edge does not exist (a dummy end node at zero distance stands for it).
    """
    n = len(tour)
    if n < 3:
        return list(tour)
    # Append a dummy end node (index len(D)) at zero distance from everything.
    E = np.zeros((len(D) + 1, len(D) + 1))
    E[:-1, :-1] = D
    p = np.array(list(tour) + [len(D)], dtype=int)
    idx = np.arange(1, n)                      # segment ends i, j in 1..n-1
    I, J = np.meshgrid(idx, idx, indexing="ij")
    upper = J > I
    limit = max_moves if max_moves is not None else 10 * n * n
    for _ in range(limit):
        a, b = p[I - 1], p[I]
        c, d = p[J], p[J + 1]
        delta = E[a, c] + E[b, d] - E[a, b] - E[c, d]
        delta = np.where(upper, delta, np.inf)
        k = int(np.argmin(delta))
        if not delta.flat[k] < -_EPS:
            break
        i, j = int(I.flat[k]), int(J.flat[k])
        p[i:j + 1] = p[i:j + 1][::-1].copy()
    return [int(v) for v in p[:-1]]


def coarsen(costmap: np.ndarray, factor: int) -> np.ndarray:
    """The costmap on cells ``factor`` times larger: each coarse cell takes the least cost of
    its factor x factor block (cells past the edge count as unknown). Optimistic: a passage
    one fine cell wide stays open, while a straight band of impassable cells 2 * factor - 1 or
    more wide stays closed (an inflated wall is the wall plus two inscribed radii: 7 or more
    0.05 m cells for a TurtleBot); a path may come out shorter by about a coarse cell per
    corner."""
    if factor == 1:
        return costmap
    r, c = costmap.shape
    R, C = -(-r // factor), -(-c // factor)
    padded = np.full((R * factor, C * factor), NO_INFORMATION, dtype=costmap.dtype)
    padded[:r, :c] = costmap
    return padded.reshape(R, factor, C, factor).min(axis=(1, 3))


def path_distance_matrix(costmap: np.ndarray, start_field: np.ndarray, goal_cells: Sequence[Cell],
                         resolution: float, cell_factor: int = 1, **dijkstra_kwargs) -> np.ndarray:
    """(n + 1, n + 1) path distances (m, costmap-weighted) for ``order``.

    Row 0 is read from ``start_field`` (the robot's cost-to-come field) at the goal cells.
    Between goals the matrix is symmetric (``prepare`` would average it anyway): goal i's row
    comes from one ``dijkstra`` run out of goal i that stops once goals i+1..n are settled, and
    is mirrored into the column. Cost: n - 1 runs, each settling the cells nearer to goal i
    than the farthest later goal: in a half-explored office every known cell (~130k at
    0.05 m, tens of ms each on a 2-core machine that also runs the simulation). Keep n to a
    few tens, and with ``cell_factor`` > 1 the runs use the ``coarsen``-ed costmap
    (factor^2 fewer cells; goal cells map to the coarse cells holding them).
    ``dijkstra_kwargs`` (settings, visits) go to every run; for a consistent matrix
    use the cost model that built ``start_field``.
    """
    n = len(goal_cells)
    cells = np.asarray(goal_cells, dtype=np.int32).reshape(n, 2)
    D = np.full((n + 1, n + 1), math.inf)
    np.fill_diagonal(D, 0.0)
    D[0, 1:] = start_field[cells[:, 0], cells[:, 1]]
    D[1:, 0] = D[0, 1:]                    # never used (nothing returns to the start)
    grid, cells = coarsen(costmap, cell_factor), cells // cell_factor
    rows, cols = cells[:, 0], cells[:, 1]
    for i in range(n - 1):
        field = dijkstra(grid, (int(rows[i]), int(cols[i])), resolution=resolution * cell_factor,
                         targets=cells[i + 1:], **dijkstra_kwargs)
        D[i + 1, i + 2:] = D[i + 2:, i + 1] = field[rows[i + 1:], cols[i + 1:]]
    return D
