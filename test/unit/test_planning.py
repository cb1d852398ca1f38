"""Planning: distance field, inflated costmap, A*, Dijkstra, nearest accessible cell, shortcut.

Every native function is checked against a plain-Python reference written here (brute-force
distance transform, heapq Dijkstra with the same cost model, Bresenham lines) on random grids
with fixed seeds, and against hand-worked numbers on small maps.
"""
import heapq
import math
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from turtlebot_recon import _native
from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.planning import (CostmapSettings, PlannerSettings, PlanningError,
                                      make_costmap, plan)
from turtlebot_recon.planning.costmap import cost_model
from turtlebot_recon.robot import load_robot

from conftest import bresenham

RES = 0.05
SQRT2 = math.sqrt(2.0)
LETHAL, INSCRIBED, UNKNOWN = 254, 253, 255

# The bindings take every argument: the planner's own values (PlannerSettings, INSCRIBED and up
# impassable, map_server's occupied threshold) at RES, unless a test gives its own.
astar = partial(_native.astar, **cost_model(PlannerSettings(), RES))
dijkstra = partial(_native.dijkstra, **cost_model(PlannerSettings(), RES))
inflate = partial(_native.inflate, occupied_threshold=OCCUPIED_THRESH, unknown_is_obstacle=False)
nearest_accessible = partial(_native.nearest_accessible, max_cost=INSCRIBED - 1, max_radius_m=2.0,
                             resolution=RES)
shortcut = partial(_native.shortcut, lethal_cost=INSCRIBED)
MOVES = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]


# ---------------------------------------------------------------- references and factories

def brute_force_distance(mask, resolution):
    """Distance (m) from every cell centre to the nearest mask cell, by checking them all."""
    rows, cols = mask.shape
    features = np.argwhere(mask != 0)
    out = np.full(mask.shape, np.inf)
    for r in range(rows):
        for c in range(cols):
            if len(features):
                out[r, c] = np.sqrt(((features - (r, c)) ** 2).sum(axis=1)).min() * resolution
    return out


def entry_factor(cost, visits, cell, visit_sensitivity, cost_weight, unknown_cost, lethal_cost):
    """Factor 1 + cost_weight c/252 + visit_sensitivity visits of entering ``cell``, or None."""
    r, c = cell
    if not (0 <= r < cost.shape[0] and 0 <= c < cost.shape[1]):
        return None
    v = int(cost[r, c])
    if v == UNKNOWN:
        if unknown_cost < 0:
            return None
        v = unknown_cost
    elif v >= lethal_cost:
        return None
    factor = 1.0 + cost_weight * v / 252.0
    if visits is not None:
        factor += visit_sensitivity * int(visits[r, c])
    return factor


def reference_dijkstra(cost, start, visits=None, visit_sensitivity=0.5, cost_weight=1.0,
                       unknown_cost=-1, lethal_cost=253, resolution=RES):
    """Cost-to-come from ``start``: heapq Dijkstra, 8-connected, no corner cutting."""
    def factor(cell):
        return entry_factor(cost, visits, cell, visit_sensitivity, cost_weight, unknown_cost,
                            lethal_cost)

    dist = np.full(cost.shape, np.inf)
    dist[start] = 0.0
    heap = [(0.0, tuple(start))]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if d > dist[r, c]:
            continue
        for dr, dc in MOVES:
            w = factor((r + dr, c + dc))
            if w is None:
                continue
            if dr and dc and (factor((r + dr, c)) is None or factor((r, c + dc)) is None):
                continue
            nd = d + resolution * (SQRT2 if dr and dc else 1.0) * w
            if nd < dist[r + dr, c + dc]:
                dist[r + dr, c + dc] = nd
                heapq.heappush(heap, (nd, (r + dr, c + dc)))
    return dist


def check_path(path, cost, start, goal, **model):
    """Assert that ``path`` is a valid 8-connected path and return its cost under ``model``."""
    resolution = model.pop("resolution", RES)
    visits = model.pop("visits", None)
    model.setdefault("visit_sensitivity", 0.5)
    model.setdefault("cost_weight", 1.0)
    model.setdefault("unknown_cost", -1)
    model.setdefault("lethal_cost", 253)

    def factor(cell):
        return entry_factor(cost, visits, cell, **model)

    assert path.dtype == np.int32 and path.ndim == 2 and path.shape[1] == 2
    assert tuple(path[0]) == tuple(start) and tuple(path[-1]) == tuple(goal)
    total = 0.0
    for (r, c), (rb, cb) in zip(path[:-1].tolist(), path[1:].tolist()):
        dr, dc = rb - r, cb - c
        assert max(abs(dr), abs(dc)) == 1, f"step {(r, c)} -> {(rb, cb)} is not to a neighbour"
        w = factor((rb, cb))
        assert w is not None, f"path enters impassable cell {(rb, cb)}"
        if dr and dc:
            assert factor((r + dr, c)) is not None and factor((r, c + dc)) is not None, \
                f"step {(r, c)} -> {(rb, cb)} cuts a corner"
        total += resolution * (SQRT2 if dr and dc else 1.0) * w
    return total


def random_rect_occupancy(rng, shape, fill=0.2, unknown=0.0):
    """int8 ROS occupancy: free (0) with random solid (100) rectangles, some unknown (-1) cells."""
    occ = np.zeros(shape, np.int8)
    while (occ == 100).mean() < fill:
        h, w = rng.integers(1, max(2, shape[0] // 4)), rng.integers(1, max(2, shape[1] // 4))
        r, c = rng.integers(0, shape[0] - h + 1), rng.integers(0, shape[1] - w + 1)
        occ[r:r + h, c:c + w] = 100
    occ[rng.random(shape) < unknown] = -1
    return occ


def random_costmap(rng, shape):
    """An inflated costmap of random rectangles with a few unknown cells and random graded costs."""
    occ = random_rect_occupancy(rng, shape, fill=rng.uniform(0.05, 0.3), unknown=0.05)
    cost = inflate(occ, RES, 0.05, rng.uniform(0.05, 0.3), rng.uniform(0.0, 10.0))
    noisy = (rng.random(shape) < 0.1) & (cost < INSCRIBED)
    cost[noisy] = rng.integers(0, 253, noisy.sum())
    return cost


def passable_cells(cost, unknown_cost=-1, lethal_cost=253):
    ok = cost < lethal_cost
    if unknown_cost >= 0:
        ok |= cost == UNKNOWN
    return np.argwhere(ok)


def ring_map():
    """A 6 x 7 lethal block with a free ring around it (row 0 is the bottom).

        row 5  . . . . . . .     start (2, 0), goal (2, 6)
        row 4  . # # # # # .     bottom route: 2 up + 6 across + 2 down = 10 steps = 0.50 m
        row 3  . # # # # # .     top route:    3 + 6 + 3                = 12 steps = 0.60 m
        row 2  S # # # # # G     (diagonals at the corners would cut the block: not allowed)
        row 1  . # # # # # .
        row 0  . . . . . . .
    """
    cost = np.full((6, 7), LETHAL, np.uint8)
    cost[0, :] = cost[5, :] = cost[:, 0] = cost[:, 6] = 0
    return cost


# ---------------------------------------------------------------- distance transform

@pytest.mark.parametrize("seed", range(12))
def test_distance_transform_is_exact(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(int(n) for n in rng.integers(1, 30, 2))
    mask = (rng.random(shape) < rng.uniform(0.01, 0.3)).astype(np.uint8)
    mask[tuple(rng.integers(0, shape))] = 1  # at least one feature
    dist = _native.distance_transform(mask, RES)
    assert dist.dtype == np.float32 and dist.shape == shape
    np.testing.assert_allclose(dist, brute_force_distance(mask, RES), rtol=1e-6, atol=1e-7)
    # scipy measures to the nearest zero: the features are the zeros of (mask == 0)
    np.testing.assert_allclose(dist, ndimage.distance_transform_edt(mask == 0) * RES,
                               rtol=1e-6, atol=1e-7)


def test_distance_transform_large_grid_matches_scipy():
    rng = np.random.default_rng(7)
    mask = (random_rect_occupancy(rng, (300, 257), fill=0.1) == 100).astype(np.uint8)
    np.testing.assert_allclose(_native.distance_transform(mask, 0.1),
                               ndimage.distance_transform_edt(mask == 0) * 0.1, rtol=1e-6)


def test_distance_transform_edge_cases():
    assert np.isinf(_native.distance_transform(np.zeros((4, 5), np.uint8), RES)).all()
    assert (_native.distance_transform(np.ones((3, 2), np.uint8), RES) == 0).all()
    assert _native.distance_transform(np.zeros((0, 0), np.uint8), RES).shape == (0, 0)
    one = np.zeros((1, 6), np.uint8)
    one[0, 4] = 1  # a single row: |c - 4| cells
    np.testing.assert_allclose(_native.distance_transform(one, 0.5)[0], [2, 1.5, 1, 0.5, 0, 0.5])
    with pytest.raises(ValueError, match="resolution"):
        _native.distance_transform(one, 0.0)
    with pytest.raises(ValueError, match="2-D"):
        _native.distance_transform(np.zeros(5, np.uint8), RES)


# ---------------------------------------------------------------- inflation

def test_inflation_values_at_hand_computed_distances():
    # One obstacle at (10, 10); inscribed r = 0.1 m, inflation 0.3 m, k = 5 /m:
    # cost = floor(252 exp(-5 (d - 0.1))) for 0.1 < d <= 0.3.
    occ = np.zeros((21, 21), np.int8)
    occ[10, 10] = 100
    cost = inflate(occ, RES, 0.1, 0.3, 5.0)
    assert cost.dtype == np.uint8
    expected = {
        (0, 0): LETHAL,          # d = 0
        (0, 1): INSCRIBED,       # d = 0.05
        (0, 2): INSCRIBED,       # d = 0.10 = r: still inscribed (<=)
        (1, 1): INSCRIBED,       # d = 0.0707
        (1, 2): 237,             # d = sqrt(5) 0.05 = 0.1118: floor(252 e^-0.0590) = floor(237.56)
        (2, 2): 204,             # d = 0.1414: floor(252 e^-0.2071) = floor(204.86)
        (0, 3): 196,             # d = 0.15: floor(252 e^-0.25) = floor(196.26)
        (0, 4): 152,             # d = 0.20 = r + 0.1: floor(252 e^-0.5) = floor(152.85)
        (3, 3): 143,             # d = 0.2121: floor(252 e^-0.5607) = floor(143.85)
        (3, 4): 119,             # d = 0.25: floor(252 e^-0.75) = floor(119.04)
        (0, 6): 92,              # d = 0.30 = inflation radius: floor(252 e^-1) = floor(92.71)
        (2, 4): 135,             # d = sqrt(20) 0.05 = 0.2236: floor(252 e^-0.6180) = floor(135.83)
        (0, 7): 0,               # d = 0.35: beyond the inflation radius
        (5, 5): 0,               # d = 0.3536: beyond
    }
    for (dr, dc), value in expected.items():
        for sr in (-1, 1):  # the field is symmetric
            for sc in (-1, 1):
                assert cost[10 + sr * dr, 10 + sc * dc] == value, (dr, dc)
                assert cost[10 + sr * dc, 10 + sc * dr] == value, (dc, dr)


def test_inflation_matches_formula_on_random_maps():
    rng = np.random.default_rng(3)
    for _ in range(10):
        occ = random_rect_occupancy(rng, (40, 50), fill=0.15, unknown=0.1)
        occ[rng.random(occ.shape) < 0.05] = 70  # uncertain cells above the threshold
        inscribed, k = rng.uniform(0.0, 0.2), rng.uniform(0.0, 8.0)
        inflation = inscribed + rng.uniform(0.0, 0.5)
        for unknown_is_obstacle in (False, True):
            cost = inflate(occ, RES, inscribed, inflation, k,
                                   unknown_is_obstacle=unknown_is_obstacle)
            obstacle = (occ >= 65) | ((occ < 0) & unknown_is_obstacle)
            d = ndimage.distance_transform_edt(~obstacle) * RES
            graded = np.floor(252 * np.exp(-k * (d - inscribed)))
            want = np.where(d <= inflation + 1e-9, graded, 0)
            want = np.where(d <= inscribed + 1e-9, INSCRIBED, want)
            want = np.where(obstacle, LETHAL, want)
            if not unknown_is_obstacle:
                want = np.where(occ < 0, UNKNOWN, want)
            # floor() may flip by one where 252 e^(...) lands within float error of an integer
            assert np.abs(cost.astype(int) - want).max() <= 1
            assert (cost == want).mean() > 0.999


def test_inflation_thresholds_and_unknown():
    occ = np.zeros((5, 9), np.int8)
    occ[2, 1] = 64   # below the threshold: free
    occ[2, 4] = 65   # at the threshold: obstacle
    occ[2, 7] = -1   # unknown
    cost = inflate(occ, 1.0, 0.0, 0.0, 1.0)  # no inflation at all
    assert cost[2, 1] == 0 and cost[2, 4] == LETHAL and cost[2, 7] == UNKNOWN
    assert (cost == 0).sum() == occ.size - 2
    cost = inflate(occ, 1.0, 1.0, 1.0, 1.0, unknown_is_obstacle=True)
    assert cost[2, 7] == LETHAL and cost[2, 8] == INSCRIBED and cost[1, 7] == INSCRIBED
    cost = inflate(occ, 1.0, 1.0, 1.0, 1.0, occupied_threshold=60)
    assert cost[2, 1] == LETHAL


def test_inflation_rejects_bad_arguments():
    occ = np.zeros((3, 3), np.int8)
    with pytest.raises(ValueError, match="inflation_radius_m .* must be >= inscribed_radius_m"):
        inflate(occ, RES, 0.3, 0.2, 5.0)
    with pytest.raises(ValueError, match="resolution"):
        inflate(occ, -1.0, 0.1, 0.2, 5.0)
    with pytest.raises(ValueError, match="cost_scaling_factor"):
        inflate(occ, RES, 0.1, 0.2, -5.0)
    with pytest.raises(ValueError, match="occupied_threshold"):
        inflate(occ, RES, 0.1, 0.2, 5.0, occupied_threshold=0)
    with pytest.raises(ValueError, match="inscribed_radius_m"):
        inflate(occ, RES, -0.1, 0.2, 5.0)


# ---------------------------------------------------------------- A* and Dijkstra

@pytest.mark.parametrize("seed", range(20))
def test_astar_is_optimal_and_valid_on_random_grids(seed):
    rng = np.random.default_rng(100 + seed)
    shape = tuple(int(n) for n in rng.integers(8, 36, 2))
    cost = random_costmap(rng, shape)
    visits = rng.integers(0, 4, shape).astype(np.int32) * (rng.random(shape) < 0.3)
    model = dict(visits=visits if seed % 2 else None, visit_sensitivity=rng.uniform(0, 1),
                 cost_weight=rng.uniform(0, 3), unknown_cost=int(rng.choice([-1, 0, 120])),
                 lethal_cost=int(rng.choice([253, 253, 254])))
    cells = passable_cells(cost, model["unknown_cost"], model["lethal_cost"])
    assert len(cells) >= 2, f"seed {seed}: the random costmap has no start and goal; pick another seed"
    start, goal = (tuple(int(v) for v in cells[i]) for i in rng.choice(len(cells), 2))
    path, total = astar(cost, start, goal, **model)
    ref = reference_dijkstra(cost, start, **model)
    field = dijkstra(cost, start, **model)
    # The native Dijkstra field is the reference field (float32).
    np.testing.assert_allclose(field, ref, rtol=1e-6)
    if np.isinf(ref[goal]):
        assert path.shape == (0, 2) and math.isinf(total)
        return
    # Optimal: A*'s tie-break scales the heuristic by (1 + 1e-9), so within 1e-9.
    assert total == pytest.approx(ref[goal], rel=1e-9)
    assert total == pytest.approx(float(field[goal]), rel=1e-6)
    assert check_path(path, cost, start, goal, **model) == pytest.approx(total, rel=1e-12)


def test_astar_on_open_floor_is_straight():
    cost = np.zeros((20, 30), np.uint8)
    path, total = astar(cost, (2, 3), (2, 25))
    assert path.tolist() == [[2, c] for c in range(3, 26)]
    assert total == pytest.approx(22 * RES)
    path, total = astar(cost, (0, 0), (10, 10))
    assert path.tolist() == [[i, i] for i in range(11)]
    assert total == pytest.approx(10 * SQRT2 * RES)
    # Off the diagonal: 5 diagonal + 10 straight steps (octile), then one straight segment.
    path, total = astar(cost, (0, 0), (5, 15))
    assert total == pytest.approx((5 * SQRT2 + 10) * RES)
    assert len(path) == 16
    assert plan(cost, (0, 0), (5, 15), PlannerSettings()).tolist() == [[0, 0], [5, 15]]


def test_start_equals_goal():
    cost = np.zeros((4, 4), np.uint8)
    path, total = astar(cost, (1, 2), (1, 2))
    assert path.tolist() == [[1, 2]] and total == 0.0
    assert plan(cost, (1, 2), (1, 2), PlannerSettings()).tolist() == [[1, 2]]


def test_visit_penalty_moves_the_path_off_visited_cells():
    cost = ring_map()
    start, goal = (2, 0), (2, 6)
    path, total = astar(cost, start, goal)
    assert total == pytest.approx(0.50) and [0, 3] in path.tolist()  # bottom route
    visits = np.zeros(cost.shape, np.int32)
    # 3 visits on (0, 3): bottom = 0.50 + 0.05 * 0.5 * 3 = 0.575 < 0.60: still the bottom.
    visits[0, 3] = 3
    path, total = astar(cost, start, goal, visits=visits)
    assert total == pytest.approx(0.575) and [0, 3] in path.tolist()
    # 5 visits: bottom = 0.50 + 0.05 * 0.5 * 5 = 0.625 > 0.60: the longer, unvisited top route.
    visits[0, 3] = 5
    path, total = astar(cost, start, goal, visits=visits)
    assert total == pytest.approx(0.60) and [5, 3] in path.tolist() and [0, 3] not in path.tolist()
    assert check_path(path, cost, start, goal, visits=visits) == pytest.approx(0.60)
    # A lower sensitivity, 0.3: bottom = 0.50 + 0.05 * 0.3 * 5 = 0.575: back to the bottom.
    path, total = astar(cost, start, goal, visits=visits, visit_sensitivity=0.3)
    assert total == pytest.approx(0.575) and [0, 3] in path.tolist()
    # Through the facade too (visited cells of the bottom route are avoided).
    route = plan(cost, start, goal, PlannerSettings(shortcut=False), visits=visits)
    assert [5, 3] in route.tolist()


def test_costmap_values_weigh_the_path():
    cost = ring_map()
    cost[0, 1:6] = 126  # bottom corridor at half cost: 10 steps, 5 of them into cost 126
    # bottom = 0.50 + 5 * 0.05 * 126 / 252 = 0.625 > top 0.60
    path, total = astar(cost, (2, 0), (2, 6))
    assert total == pytest.approx(0.60) and [5, 3] in path.tolist()
    # cost_weight 0: the costmap only forbids; the shorter bottom route wins again.
    path, total = astar(cost, (2, 0), (2, 6), cost_weight=0.0)
    assert total == pytest.approx(0.50) and [0, 3] in path.tolist()


def test_unknown_cells_forbidden_or_priced():
    # A one-cell corridor (row 1) whose middle cell is unknown; everything else lethal.
    cost = np.full((3, 5), LETHAL, np.uint8)
    cost[1, :] = 0
    cost[1, 2] = UNKNOWN
    path, total = astar(cost, (1, 0), (1, 4))  # unknown_cost = -1: forbidden
    assert path.shape == (0, 2) and math.isinf(total)
    with pytest.raises(PlanningError, match="unreachable"):
        plan(cost, (1, 0), (1, 4), PlannerSettings())
    # Allowed at cost 100: 4 steps of 0.05 m, one into the unknown cell:
    # 0.20 + 0.05 * 100 / 252 = 0.21984
    path, total = astar(cost, (1, 0), (1, 4), unknown_cost=100)
    assert path.tolist() == [[1, c] for c in range(5)]
    assert total == pytest.approx(0.20 + 0.05 * 100 / 252)
    assert astar(cost, (1, 0), (1, 4), unknown_cost=0)[1] == pytest.approx(0.20)
    # A goal in unknown space is named.
    with pytest.raises(ValueError, match=r"goal \(1, 2\) is in unknown space"):
        astar(cost, (1, 0), (1, 2))
    assert len(plan(cost, (1, 0), (1, 2), PlannerSettings(unknown_cost=50, shortcut=False))) == 3


def test_inscribed_cells_are_impassable_unless_lethal_cost_is_raised():
    cost = np.full((3, 5), LETHAL, np.uint8)
    cost[1, :] = 0
    cost[1, 2] = INSCRIBED
    assert astar(cost, (1, 0), (1, 4))[0].shape == (0, 2)
    path, total = astar(cost, (1, 0), (1, 4), lethal_cost=254)
    assert len(path) == 5 and total == pytest.approx(0.20 + 0.05 * 253 / 252)


@pytest.mark.parametrize("seed", range(10))
def test_dijkstra_with_targets_settles_them_exactly_and_stops(seed):
    rng = np.random.default_rng(300 + seed)
    shape = tuple(int(n) for n in rng.integers(10, 40, 2))
    cost = random_costmap(rng, shape)
    cells = passable_cells(cost, -1, 253)
    assert len(cells) >= 4, f"seed {seed}: the random costmap has no start and 3 targets; pick another seed"
    start = tuple(int(v) for v in cells[0])
    full = dijkstra(cost, start)
    targets = cells[rng.choice(len(cells), 3, replace=False)].astype(np.int32)
    part = dijkstra(cost, start, targets=targets)
    settled = np.isfinite(part)
    # Every settled cell holds its exact cost, every target reachable at all is settled, and
    # the search stopped at the dearest target: nothing dearer was settled.
    np.testing.assert_array_equal(part[settled], full[settled])
    reach = full[targets[:, 0], targets[:, 1]]
    np.testing.assert_array_equal(part[targets[:, 0], targets[:, 1]], reach)
    if np.isfinite(reach).all():
        assert part[settled].max() <= reach.max()
        assert settled.sum() <= np.isfinite(full).sum()
    else:                                       # an unreachable target: the whole search
        np.testing.assert_array_equal(part, full)


def test_dijkstra_targets_stop_early_and_are_checked():
    cost = np.zeros((50, 50), np.uint8)
    part = dijkstra(cost, (0, 0), targets=np.array([[2, 2]]))
    assert part[2, 2] == pytest.approx(2 * math.sqrt(2) * RES, rel=1e-6)
    assert np.isinf(part[49, 49]) and np.isfinite(part).sum() < 50
    np.testing.assert_array_equal(dijkstra(cost, (0, 0), targets=np.zeros((0, 2), np.int32)),
                                  dijkstra(cost, (0, 0)))
    with pytest.raises(ValueError, match=r"dijkstra: target \(50, 0\) is outside the 50 x 50 grid"):
        dijkstra(cost, (0, 0), targets=[[1, 1], [50, 0]])
    with pytest.raises(ValueError, match=r"targets must be an \(n, 2\) array"):
        dijkstra(cost, (0, 0), targets=[1, 2, 3])


def test_no_corner_cutting():
    cost = np.zeros((2, 2), np.uint8)
    cost[0, 1] = LETHAL
    path, total = astar(cost, (0, 0), (1, 1))
    assert path.tolist() == [[0, 0], [1, 0], [1, 1]] and total == pytest.approx(0.10)
    cost[1, 0] = LETHAL  # both orthogonal cells blocked: the diagonal is not a way through
    assert astar(cost, (0, 0), (1, 1))[0].shape == (0, 2)
    assert np.isinf(dijkstra(cost, (0, 0))[1, 1])


def test_endpoint_errors_name_the_endpoint():
    cost = np.zeros((5, 6), np.uint8)
    cost[3, 4] = LETHAL
    cost[0, 5] = INSCRIBED
    with pytest.raises(ValueError, match=r"astar: start \(3, 4\) is in lethal cost 254"):
        astar(cost, (3, 4), (0, 0))
    with pytest.raises(ValueError, match=r"astar: goal \(0, 5\) is in inscribed cost 253"):
        astar(cost, (0, 0), (0, 5))
    with pytest.raises(ValueError, match=r"astar: start \(-1, 0\) is outside the 5 x 6 grid"):
        astar(cost, (-1, 0), (0, 0))
    with pytest.raises(ValueError, match=r"astar: goal \(0, 6\) is outside"):
        astar(cost, (0, 0), (0, 6))
    with pytest.raises(ValueError, match=r"dijkstra: start \(3, 4\)"):
        dijkstra(cost, (3, 4))
    with pytest.raises(PlanningError, match=r"start \(3, 4\)"):
        plan(cost, (3, 4), (0, 0), PlannerSettings())
    with pytest.raises(PlanningError, match=r"goal \(9, 9\) is outside"):
        plan(cost, (0, 0), (9, 9), PlannerSettings())


def test_search_rejects_bad_arguments():
    cost = np.zeros((4, 4), np.uint8)
    with pytest.raises(ValueError, match="visits has shape"):
        astar(cost, (0, 0), (3, 3), visits=np.zeros((3, 4), np.int32))
    with pytest.raises(ValueError, match="visits must be >= 0"):
        astar(cost, (0, 0), (3, 3), visits=-np.ones((4, 4), np.int32))
    with pytest.raises(ValueError, match="visit_sensitivity"):
        astar(cost, (0, 0), (3, 3), visit_sensitivity=-0.1)
    with pytest.raises(ValueError, match="cost_weight"):
        dijkstra(cost, (0, 0), cost_weight=-1.0)
    with pytest.raises(ValueError, match="lethal_cost"):
        astar(cost, (0, 0), (3, 3), lethal_cost=255)
    with pytest.raises(ValueError, match="unknown_cost"):
        astar(cost, (0, 0), (3, 3), unknown_cost=253)
    with pytest.raises(ValueError, match="resolution"):
        astar(cost, (0, 0), (3, 3), resolution=0.0)


def test_resolution_scales_only_the_cost():
    rng = np.random.default_rng(5)
    cost = random_costmap(rng, (30, 30))
    cells = passable_cells(cost)
    start, goal = tuple(cells[0]), tuple(cells[-1])
    p1, c1 = astar(cost, start, goal, resolution=0.05)
    p2, c2 = astar(cost, start, goal, resolution=0.10)
    if len(p1):
        assert c2 == pytest.approx(2 * c1)


# ---------------------------------------------------------------- nearest accessible cell

def reference_nearest(cost, cell, max_cost, max_radius_m, resolution):
    best = None
    for r, c in np.ndindex(cost.shape):
        if cost[r, c] == UNKNOWN or cost[r, c] > max_cost:
            continue
        d2 = (r - cell[0]) ** 2 + (c - cell[1]) ** 2
        if math.sqrt(d2) * resolution > max_radius_m + 1e-9:
            continue
        if best is None or (d2, r, c) < best:
            best = (d2, r, c)
    return None if best is None else (best[1], best[2])


def test_nearest_accessible_hand_made():
    cost = np.full((11, 11), LETHAL, np.uint8)
    assert nearest_accessible(cost, (5, 5)) is None
    cost[5, 8] = 0   # 3 cells right
    cost[8, 5] = 0   # 3 cells up
    cost[2, 5] = 0   # 3 cells down: the tie goes to the smallest row
    assert nearest_accessible(cost, (5, 5)) == (2, 5)
    assert nearest_accessible(cost, (5, 8)) == (5, 8)   # accessible itself
    # The radius is inclusive: 3 cells = 0.15 m.
    assert nearest_accessible(cost, (5, 5), max_radius_m=0.15) == (2, 5)
    assert nearest_accessible(cost, (5, 5), max_radius_m=0.149) is None
    # Unknown cells never count, whatever max_cost allows; max_cost is inclusive.
    cost[5, 5] = UNKNOWN
    cost[5, 4] = 200
    # max_cost 254 accepts lethal cells: of the four at distance 1, (4, 5) has the smallest row.
    assert nearest_accessible(cost, (5, 5), max_cost=254) == (4, 5)
    assert nearest_accessible(cost, (5, 5), max_cost=200) == (5, 4)
    assert nearest_accessible(cost, (5, 5), max_cost=199) == (2, 5)
    # From outside the grid: (-3, 5) is 5 cells from (2, 5).
    assert nearest_accessible(cost, (-3, 5), max_radius_m=0.25) == (2, 5)
    assert nearest_accessible(cost, (-3, 5), max_radius_m=0.2) is None
    with pytest.raises(ValueError, match="max_cost"):
        nearest_accessible(cost, (5, 5), max_cost=255)


def test_nearest_accessible_matches_brute_force():
    rng = np.random.default_rng(11)
    for _ in range(40):
        cost = random_costmap(rng, (25, 31))
        cell = tuple(int(v) for v in rng.integers(-5, 35, 2))
        max_cost, radius = int(rng.integers(0, 253)), float(rng.uniform(0, 1.5))
        got = nearest_accessible(cost, cell, max_cost=max_cost, max_radius_m=radius)
        assert got == reference_nearest(cost, cell, max_cost, radius, RES)


# ---------------------------------------------------------------- shortcut

def assert_valid_shortcut(short, path, cost, lethal_cost=253):
    """Kept points are path points in order (first and last included); every segment stays,
    after its first cell, on cells below lethal_cost and no costlier than the path after its
    first cell up to its end."""
    index = {tuple(p): i for i, p in enumerate(path.tolist())}
    assert tuple(short[0]) == tuple(path[0]) and tuple(short[-1]) == tuple(path[-1])
    kept = [index[tuple(p)] for p in short.tolist()]
    assert kept == sorted(kept) and len(set(kept)) == len(kept)
    for a, b in zip(kept[:-1], kept[1:]):
        ceiling = max(int(cost[tuple(p)]) for p in path[a + 1:b + 1].tolist())
        for cell in bresenham(tuple(path[a]), tuple(path[b]))[1:]:
            assert cost[cell] < lethal_cost, f"segment {a}->{b} crosses {cell}"
            assert cost[cell] <= ceiling, f"segment {a}->{b} runs closer to obstacles at {cell}"


def test_shortcut_around_a_corner():
    # An L-shaped path along row 0 then up column 9, around a lethal block (rows 2-9, cols 0-7).
    cost = np.zeros((10, 10), np.uint8)
    cost[2:, :8] = LETHAL
    path = np.array([[0, c] for c in range(10)] + [[r, 9] for r in range(1, 10)], np.int32)
    short = shortcut(path, cost)
    # (0, 0) -> (1, 9) stays in rows 0-1; any line to (r >= 2, 9) enters row 2 before col 8.
    assert short.tolist() == [[0, 0], [1, 9], [9, 9]]
    assert_valid_shortcut(short, path, cost)
    # Without the block the whole path is one segment.
    assert shortcut(path, np.zeros_like(cost)).tolist() == [[0, 0], [9, 9]]


def test_shortcut_never_runs_closer_to_obstacles_than_the_path():
    # The same L, but the block is graded cost 100 (passable): the path itself stays on cost 0,
    # so a shortcut may not cross the block either.
    cost = np.zeros((7, 7), np.uint8)
    cost[2:, :6] = 100
    path = np.array([[0, c] for c in range(7)] + [[r, 6] for r in range(1, 7)], np.int32)
    short = shortcut(path, cost)
    assert short.tolist() == [[0, 0], [1, 6], [6, 6]]
    assert_valid_shortcut(short, path, cost)
    # If the path itself passes a cost-100 cell, lines up to cost 100 become acceptable.
    cost[0, 6] = 100
    assert shortcut(path, cost).tolist() == [[0, 0], [6, 6]]
    # ... but never a lethal one, even below the path's own highest cost.
    cost[3, 3] = LETHAL
    short = shortcut(path, cost)
    assert len(short) > 2
    assert_valid_shortcut(short, path, cost)


def test_shortcut_from_a_start_beside_a_wall_leaves_the_wall_as_the_path_does():
    # The robot stands in a wall's band (column 0, cost 220); the path steps away from it at
    # once (column 1, 150; then column 2, 0) and runs up column 2. The start cell's cost does
    # not license a line along the wall: no cell after the first may cost more than 150.
    cost = np.zeros((12, 6), np.uint8)
    cost[:, 0], cost[:, 1] = 220, 150
    path = np.array([[0, 0], [1, 1]] + [[r, 2] for r in range(2, 12)], np.int32)
    short = shortcut(path, cost)
    assert_valid_shortcut(short, path, cost)
    assert short.tolist() == [[0, 0], [4, 2], [11, 2]]      # (0, 0) -> (4, 2) crosses column 1 only
    # (with the start's 220 as the ceiling, (0, 0) -> (11, 2) would run up columns 0 and 1)
    assert any(cost[cell] == 220 for cell in bresenham((0, 0), (11, 2))[1:])


@pytest.mark.parametrize("seed", range(10))
def test_shortcut_of_astar_paths_on_random_maps(seed):
    rng = np.random.default_rng(200 + seed)
    occ = random_rect_occupancy(rng, (60, 60), fill=0.15)
    cost = inflate(occ, RES, 0.05, 0.25, 5.0)
    cells = passable_cells(cost)
    start = tuple(int(v) for v in cells[rng.integers(len(cells))])
    # the goal: a cell the start reaches that is not its neighbour, so the path has >= 3 cells
    field = dijkstra(cost, start)
    goals = cells[np.isfinite(field[cells[:, 0], cells[:, 1]])
                  & (np.abs(cells - start).max(axis=1) >= 2)]
    assert len(goals), f"seed {seed}: the start reaches no cell two steps away; pick another seed"
    goal = tuple(int(v) for v in goals[rng.integers(len(goals))])
    path, _ = astar(cost, start, goal)
    assert len(path) >= 3
    short = shortcut(path, cost)
    assert short.dtype == np.int32
    assert len(short) < len(path)
    assert_valid_shortcut(short, path, cost)


def test_shortcut_short_paths_are_unchanged():
    cost = np.zeros((5, 5), np.uint8)
    for pts in ([], [[1, 1]], [[1, 1], [2, 2]]):
        path = np.array(pts, np.int32).reshape(-1, 2)
        assert shortcut(path, cost).tolist() == pts
    straight = np.array([[2, c] for c in range(5)], np.int32)
    assert shortcut(straight, cost).tolist() == [[2, 0], [2, 4]]
    with pytest.raises(ValueError, match="outside the grid"):
        shortcut(np.array([[0, 0], [7, 7], [1, 1]], np.int32), cost)


# ---------------------------------------------------------------- facade

def test_costmap_settings_for_robots():
    burger = CostmapSettings.for_robot(load_robot("turtlebot3_burger"))
    assert burger.inscribed_radius_m == pytest.approx(0.105)
    assert burger.inflation_radius_m == pytest.approx(0.455)
    assert burger.cost_scaling_factor == 5.0
    waffle = CostmapSettings.for_robot(load_robot("turtlebot3_waffle_pi"))
    # the circumscribed radius about the axle: the body sweeps that disc turning in place
    assert waffle.inscribed_radius_m == pytest.approx(0.257)
    kobuki = CostmapSettings.for_robot(load_robot("turtlebot2"))
    assert kobuki.inscribed_radius_m == pytest.approx(0.177)
    for s in (burger, waffle, kobuki):
        s.validate("test")


def test_settings_validation():
    with pytest.raises(ConfigError, match="inflation_radius_m"):
        from_dict(CostmapSettings, {"inscribed_radius_m": 0.3, "inflation_radius_m": 0.2}, "cm")
    with pytest.raises(ConfigError, match="unknown_cost"):
        from_dict(PlannerSettings, {"unknown_cost": 300}, "pl")
    with pytest.raises(ConfigError, match="visit_sensitivity"):
        from_dict(PlannerSettings, {"visit_sensitivity": -1.0}, "pl")
    assert from_dict(PlannerSettings, {"unknown_cost": 0}, "pl").unknown_cost == 0


def test_make_costmap_and_plan_end_to_end():
    occ = np.zeros((40, 60), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[:30, 30] = 100                       # a wall with a gap at the top
    settings = CostmapSettings(inscribed_radius_m=0.1, inflation_radius_m=0.3)
    cost = make_costmap(occ, RES, settings)
    # both radii one cell diagonal further out: obstacle and robot each sit anywhere in a cell
    margin = RES * math.sqrt(2.0)
    np.testing.assert_array_equal(cost, inflate(occ, RES, 0.1 + margin, 0.3 + margin, 5.0))
    # (31, 31) is sqrt(5) cells = 0.112 m from the wall's end (29, 30): beyond the 0.1 m
    # radius from its centre, but within 0.1 m of its edge
    assert cost[31, 31] == 253 and inflate(occ, RES, 0.1, 0.3, 5.0)[31, 31] < 253
    start, goal = (5, 10), (5, 50)
    raw = plan(cost, start, goal, PlannerSettings(shortcut=False))
    short = plan(cost, start, goal, PlannerSettings())
    assert raw.dtype == short.dtype == np.int32
    check_path(raw, cost, start, goal)
    assert max(raw[:, 0]) >= 32              # it goes round the wall's end (row 29 + 3 cells)
    assert 3 <= len(short) < len(raw)
    assert_valid_shortcut(short, raw, cost)


def test_planning_package_has_no_rospy():
    pkg = Path(__file__).resolve().parents[2] / "src" / "turtlebot_recon" / "planning"
    for source in pkg.glob("*.py"):
        assert "rospy" not in source.read_text(), source
