"""Seed 003's RRT (planning.rrt_seed003, include/turtlebot_recon/rrt_seed003.hpp).

Every path is checked by ``box_free_along``, written here independently of the C++: the
axis-aligned hit-box (half-side h cells) centred at a point p overlaps obstacle cell (r, c) when
the open intervals meet, c < p.x + h < c + 1 + 2h, likewise in y; cells off the grid count as
obstacles; a segment is sampled 2,000 times. Maps are hand-made at 0.05 m, origin (0, 0), so
cell (row, col) spans x in [col, col + 1] x 0.05, y in [row, row + 1] x 0.05. The burger's
0.21 m disc gives a hit-box of ceil(4.2) + 3 = 8 cells (0.4 m), the waffle_pi's 0.306 m box
ceil(6.12) + 3 = 10 cells, the seed's own.
"""
import math
import re
from pathlib import Path

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.config import ConfigError
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.planning import PlanningError
from turtlebot_recon.planning.rrt_seed003 import (RrtSeed003Settings, hitbox_cells,
                                                  plan_rrt_seed003)
from turtlebot_recon.robot import footprint_args, load_robot

RES = 0.05
ORIGIN = (0.0, 0.0)
BURGER = load_robot("turtlebot3_burger")
WAFFLE = load_robot("turtlebot3_waffle_pi")
SEED = RrtSeed003Settings()


def walled(rows, cols):
    occ = np.zeros((rows, cols), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    return occ


def corridor_bend():
    """A 3 x 6 m room split by a wall at columns 58-61 from the bottom up to row 39: the only
    way from the left half to the right is over the wall's top, a 1 m (20-row) opening."""
    occ = walled(60, 120)
    occ[:40, 58:62] = 100
    return occ


def cells(xy):
    return (xy[0] - ORIGIN[0]) / RES, (xy[1] - ORIGIN[1]) / RES


def box_free_at(occ, x, y, half):
    rows, cols = occ.shape
    c0, c1 = math.floor(x - half), math.ceil(x + half) - 1
    r0, r1 = math.floor(y - half), math.ceil(y + half) - 1
    if r0 < 0 or c0 < 0 or r1 >= rows or c1 >= cols:
        return False
    return not (occ[r0:r1 + 1, c0:c1 + 1] >= OCCUPIED_THRESH).any()


def box_free_along(occ, a, b, side, samples=2000):
    """The reference: the hit-box of ``side`` cells at ``samples`` points along a -> b (cells)."""
    t = np.linspace(0.0, 1.0, samples)
    return all(box_free_at(occ, a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), 0.5 * side) for s in t)


def native_free_along(occ, segments, side):
    return _native.rrt_seed003_free_along(occ, np.asarray(segments, float).reshape(-1, 4), hitbox_width_cells=side,
                                          hitbox_length_cells=side, occupied_threshold=OCCUPIED_THRESH,
                                          unknown_is_obstacle=True)


def raw(occ, start, goal, seed=0, **overrides):
    """The binding itself (its counts are returned when no path is found)."""
    args = dict(goal_fraction=0.3, step_cells=4.0, hitbox_width_cells=8, hitbox_length_cells=8, max_steps=25000,
                max_nodes=10000, shortcut=True, occupied_threshold=OCCUPIED_THRESH, unknown_is_obstacle=True)
    args.update(overrides)
    return _native.rrt_seed003(occ, start, goal, seed=seed, **args)


# ---------------------------------------------------------------- the seed's values, the hit-box rule

def test_settings_default_to_the_seeds_values():
    assert (SEED.goal_select_fraction, SEED.step_cells, SEED.max_steps, SEED.max_nodes) == (0.3, 4.0, 25000, 10000)
    assert SEED.shortcut


def test_cpp_defaults_are_the_python_settings():
    # the header's struct keeps the seed's values too (a C++ caller's defaults): the same numbers
    text = (Path(__file__).resolve().parents[2] / "include" / "turtlebot_recon" / "rrt_seed003.hpp").read_text()
    body = re.search(r"struct RrtSeed003Params \{(.*?)\n\};", text, re.S).group(1)
    cpp = {m.group(1): float(m.group(2)) for m in re.finditer(r"^\s*(?:double|int)\s+(\w+)\s*=\s*([-+0-9.e]+);", body, re.M)}
    assert cpp == {"goal_fraction": SEED.goal_select_fraction, "step_cells": SEED.step_cells,
                   "hitbox_width_cells": 7 + SEED.clearance_cells, "hitbox_length_cells": 7 + SEED.clearance_cells,
                   "max_steps": SEED.max_steps, "max_nodes": SEED.max_nodes, "occupied_threshold": OCCUPIED_THRESH}


def test_hitbox_is_the_footprint_in_cells_plus_the_seeds_clearance():
    assert hitbox_cells(WAFFLE, RES, SEED) == 10       # 0.306 m -> 7 cells + 3: the seed's 10 x 10
    assert hitbox_cells(BURGER, RES, SEED) == 8        # 2 x 0.105 m -> 5 cells + 3
    assert hitbox_cells(BURGER, 0.025, SEED) == 12     # 0.21 / 0.025 = 8.4 -> 9 + 3
    assert hitbox_cells(BURGER, RES, RrtSeed003Settings(clearance_cells=0)) == 5


def test_bad_settings_are_refused_naming_the_key():
    with pytest.raises(ConfigError, match="goal_select_fraction"):
        plan_rrt_seed003(walled(20, 20), RES, ORIGIN, BURGER, (0.5, 0.5), (0.6, 0.5),
                         RrtSeed003Settings(goal_select_fraction=1.5))
    with pytest.raises(ConfigError, match="step_cells"):
        RrtSeed003Settings(step_cells=0).validate("RrtSeed003Settings")


# ---------------------------------------------------------------- paths

def test_path_through_the_corridor_is_valid_and_collision_free():
    occ = corridor_bend()
    start, goal = (0.75, 0.75), (5.25, 0.75)
    path = plan_rrt_seed003(occ, RES, ORIGIN, BURGER, start, goal, seed=3)
    pts = path.points
    assert np.allclose(pts[0], start) and np.allclose(pts[-1], goal)
    assert pts[:, 1].max() > 40 * RES                  # over the wall's top (row 40 up)
    for a, b in zip(pts[:-1], pts[1:]):
        assert box_free_along(occ, cells(a), cells(b), path.hitbox_cells)
    # the burger's own disc along the path stays off every wall (the hit-box holds it with room)
    dense = np.concatenate([np.linspace(a, b, max(2, int(np.ceil(np.linalg.norm(b - a) / (0.5 * RES))) + 1))
                            for a, b in zip(pts[:-1], pts[1:])])
    clearance = _native.footprint_clearance(occ, RES, ORIGIN, np.column_stack([dense, np.zeros(len(dense))]),
                                            max_m=1.0, occupied_threshold=OCCUPIED_THRESH,
                                            unknown_is_obstacle=True, **footprint_args(BURGER))
    assert clearance.min() >= 1.5 * RES - 1e-9         # (8 - 5 cells) / 2 at least, in fact
    assert path.length_m == pytest.approx(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    assert path.length_m >= math.dist(start, goal)
    assert path.steps <= SEED.max_steps and path.nodes <= SEED.max_nodes
    assert path.hitbox_cells == 8


def test_same_seed_same_path_other_seed_other_tree():
    occ = corridor_bend()
    a = plan_rrt_seed003(occ, RES, ORIGIN, BURGER, (0.75, 0.75), (5.25, 0.75), seed=7)
    b = plan_rrt_seed003(occ, RES, ORIGIN, BURGER, (0.75, 0.75), (5.25, 0.75), seed=7)
    c = plan_rrt_seed003(occ, RES, ORIGIN, BURGER, (0.75, 0.75), (5.25, 0.75), seed=8)
    assert np.array_equal(a.points, b.points) and a.steps == b.steps
    assert (a.steps, a.nodes) != (c.steps, c.nodes)


def test_waffle_pi_hitbox_does_not_fit_a_gap_narrower_than_half_a_metre():
    # a wall across the room with a 0.45 m (9-cell) door: the waffle_pi's 10-cell hit-box cannot
    # pass (its box would, turned: the seed's hit-box is the baseline's limit), the burger's 8 can
    occ = walled(60, 120)
    occ[:, 58:62] = 100
    occ[25:34, 58:62] = 0
    with pytest.raises(PlanningError, match="no path"):
        plan_rrt_seed003(occ, RES, ORIGIN, WAFFLE, (1.0, 1.5), (5.0, 1.5))
    assert plan_rrt_seed003(occ, RES, ORIGIN, BURGER, (1.0, 1.5), (5.0, 1.5)).length_m >= 4.0


def test_walled_off_goal_is_no_path_within_the_limits():
    occ = corridor_bend()
    occ[:, 58:62] = 100                                # the opening closed
    with pytest.raises(PlanningError, match=r"no path .* 25000 steps"):
        plan_rrt_seed003(occ, RES, ORIGIN, BURGER, (0.75, 0.75), (5.25, 0.75))
    out = raw(occ, cells((0.75, 0.75)), cells((5.25, 0.75)))
    assert not out["found"] and len(out["path"]) == 0
    assert out["steps"] == 25000 and out["nodes"] < 10000     # SMAX bounds the search; the left half fills long before NMAX
    few = raw(occ, cells((0.75, 0.75)), cells((5.25, 0.75)), max_nodes=50)
    assert few["nodes"] == 50 and few["steps"] < 25000         # NMAX ends it first


def test_goal_bias_holds_statistically():
    # With the goal walled off every step samples; over N = 25,000 steps the goal count is
    # Binomial(N, 0.3): sd sqrt(N 0.3 0.7) = 72.5, so 4.5 sd is 326 (1.3 %)
    occ = corridor_bend()
    occ[:, 58:62] = 100
    for seed in (0, 1, 2):
        out = raw(occ, cells((0.75, 0.75)), cells((5.25, 0.75)), seed=seed)
        n, k = out["steps"], out["goal_samples"]
        assert abs(k - 0.3 * n) <= 4.5 * math.sqrt(n * 0.3 * 0.7), (seed, n, k)
    assert raw(occ, cells((0.75, 0.75)), cells((5.25, 0.75)), goal_fraction=0.0)["goal_samples"] == 0
    always = raw(occ, cells((0.75, 0.75)), cells((5.25, 0.75)), goal_fraction=1.0, max_steps=300)
    assert always["goal_samples"] == always["steps"] == 300


@pytest.mark.parametrize("start, goal, words", [
    ((-0.2, 1.0), (5.0, 1.0), "start .* off the"),
    ((1.0, 1.0), (5.0, 3.5), "goal .* off the"),
    ((2.95, 0.5), (5.0, 1.0), "start .* inside an obstacle"),
    ((1.0, 1.0), (0.01, 1.0), "goal .* inside an obstacle"),
    ((0.1, 1.0), (5.0, 1.0), "start .* hit-box meets an obstacle"),
    ((1.0, 1.0), (2.8, 0.5), "goal .* hit-box meets an obstacle"),
])
def test_start_or_goal_off_the_map_or_in_an_obstacle_is_one_clear_line(start, goal, words):
    with pytest.raises(PlanningError, match=words) as err:
        plan_rrt_seed003(corridor_bend(), RES, ORIGIN, BURGER, start, goal)
    assert "\n" not in str(err.value)


# ---------------------------------------------------------------- the hit-box sweep and the shortcut

def test_native_sweep_matches_the_sampled_reference_on_random_segments():
    rng = np.random.default_rng(4)
    occ = walled(40, 40)
    for _ in range(25):                                # random blocks
        r, c = rng.integers(1, 37, size=2)
        occ[r:r + rng.integers(1, 4), c:c + rng.integers(1, 4)] = 100
    segments = np.column_stack([rng.uniform(2, 38, size=(400, 2)), rng.uniform(2, 38, size=(400, 2))])
    segments[:, 2:] = segments[:, :2] + np.clip(segments[:, 2:] - segments[:, :2], -6, 6)
    for side in (3, 4, 8):
        native = native_free_along(occ, segments, side)
        ref = [box_free_along(occ, s[:2], s[2:], side) for s in segments]
        assert list(native) == ref
        assert 0 < native.sum() < len(native)          # both answers occur


def test_shortcut_leaves_no_redundant_vertex_and_keeps_the_path_clear():
    occ = walled(80, 120)                              # a zig-zag: two staggered walls
    occ[:55, 38:42] = 100
    occ[25:, 78:82] = 100
    start, goal = cells((0.5, 0.5)), cells((5.5, 3.5))
    for seed in range(6):
        out = raw(occ, start, goal, seed=seed)
        tree, path = out["tree_path"], out["path"]
        assert out["found"] and np.allclose(path[0], start) and np.allclose(path[-1], goal)
        assert 3 <= len(path) < len(tree)
        # the two-pointer rule: each kept vertex reaches no farther than the next one kept
        skips = np.column_stack([path[:-2], path[2:]])
        assert not native_free_along(occ, skips, 8).any()
        # the kept vertices are tree vertices in order, and every kept segment is clear
        index = [int(np.flatnonzero(np.all(np.isclose(tree, p), axis=1))[0]) for p in path]
        assert index == sorted(index)
        for a, b in zip(path[:-1], path[1:]):
            assert box_free_along(occ, a, b, 8)
    plain = raw(occ, start, goal, seed=0, shortcut=False)
    assert np.array_equal(plain["path"], plain["tree_path"])
