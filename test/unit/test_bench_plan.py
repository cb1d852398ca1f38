"""bench-plan's own logic (test/benchmarks/bench_plan.py) on a tiny map: the pairs it draws are
reachable, its collision check catches a path through a wall or a turn the box has no room for,
and plan.json's keys are there with the numbers worked by hand.

The map: 3 x 2 m at 0.05 m (40 rows, 60 columns, a one-cell wall all round), split by a wall at
columns 28-31 with a 0.6 m door at rows 14-25 (y in [0.70, 1.30]).
"""
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_plan  # noqa: E402

from turtlebot_recon.planning import plan_lattice  # noqa: E402
from turtlebot_recon.robot import load_robot  # noqa: E402

RES = 0.05
ORIGIN = (0.0, 0.0)
WAFFLE = load_robot("turtlebot3_waffle_pi")
BURGER = load_robot("turtlebot3_burger")


def two_rooms():
    occ = np.zeros((40, 60), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[:, 28:32] = 100
    occ[14:26, 28:32] = 0
    return occ


@pytest.fixture(scope="module")
def pairs():
    return {r.name: bench_plan.sample_pairs(two_rooms(), RES, ORIGIN, r, 4, seed=1) for r in (WAFFLE, BURGER)}


def test_pairs_are_reachable_lattice_poses_at_least_a_metre_apart(pairs):
    occ = two_rooms()
    for robot in (WAFFLE, BURGER):
        got = pairs[robot.name]
        assert [p.index for p in got] == [0, 1, 2, 3]
        for p in got:
            assert math.dist(p.start[:2], p.goal[:2]) >= bench_plan.MIN_PAIR_DISTANCE_M
            for pose in (p.start, p.goal):      # the lattice's 0.02 m margin + 1 mm, no pose on it
                assert bench_plan.check_path(occ, RES, ORIGIN, robot, np.array([pose, pose]))[1] >= 0.021 - 1e-9
            path = plan_lattice(occ, RES, ORIGIN, robot, p.start, p.goal[:2], bench_plan.navigator_lattice())
            assert p.reference_m <= path.length_m + 1e-9      # the reference is the shortest driven
            assert p.reference_m >= math.dist(p.start[:2], p.goal[:2]) - 1e-9
    again = bench_plan.sample_pairs(occ, RES, ORIGIN, BURGER, 4, seed=1)
    assert again == pairs[BURGER.name]                          # a fixed seed, the same pairs


def test_no_pairs_where_the_robot_fits_nowhere_is_an_error():
    occ = np.full((20, 20), 100, np.int8)
    occ[5:15, 5:8] = 0                                          # 0.15 m wide: neither robot fits
    with pytest.raises(RuntimeError, match="only 0 of 2 pairs"):
        bench_plan.sample_pairs(occ, RES, ORIGIN, BURGER, 2, seed=0, tries_per_pair=20)


def test_collision_check_catches_a_path_through_the_wall():
    occ = two_rooms()
    through = np.array([[0.5, 0.5], [2.5, 0.5]])                 # straight through the wall at y 0.5
    via_door = np.array([[0.5, 0.5], [1.0, 1.0], [2.0, 1.0], [2.5, 0.5]])
    for robot in (WAFFLE, BURGER):
        assert not bench_plan.check_path(occ, RES, ORIGIN, robot, through)[0]
        clear, least = bench_plan.check_path(occ, RES, ORIGIN, robot, via_door)
        assert clear and 0 < least < 0.3
    # the door is 0.6 m: through its middle the burger's disc keeps 0.3 - 0.105 = 0.195 m
    mid = np.array([[1.0, 1.0], [2.0, 1.0]])
    assert bench_plan.check_path(occ, RES, ORIGIN, BURGER, mid)[1] == pytest.approx(0.195, abs=1e-6)


def test_collision_check_sweeps_turns_in_place():
    # a 0.40 x 0.40 m pocket, x, y in [0.5, 0.9]; the waffle_pi's box is 0.281 x 0.306 m, its
    # centre 0.064 m behind base_footprint. With base_footprint at (0.725, 0.725) the box spans
    # x [0.5205, 0.8015], y [0.572, 0.878] at yaw 0, and x [0.572, 0.878], y [0.5205, 0.8015] at
    # 90 degrees: both fit; at 45 degrees its 0.415 m diagonal does not
    occ = np.full((30, 30), 100, np.int8)
    occ[10:18, 10:18] = 0
    x = y = 0.725
    for yaw in (0.0, math.pi / 2):
        assert bench_plan.check_path(occ, RES, ORIGIN, WAFFLE, np.array([[x, y, yaw], [x, y, yaw]]))[0]
    assert not bench_plan.check_path(occ, RES, ORIGIN, WAFFLE, np.array([[x, y, 0.0], [x, y, math.pi / 2]]))[0]
    # a 2-D path turns in place at its vertices: 1 mm east, then 1 mm north
    corner = np.array([[x, y], [x + 0.001, y], [x + 0.001, y + 0.001]])
    for leg in (corner[:2], corner[1:]):
        assert bench_plan.check_path(occ, RES, ORIGIN, WAFFLE, leg)[0]
    assert not bench_plan.check_path(occ, RES, ORIGIN, WAFFLE, corner)[0]


def test_densify_drives_backward_where_the_planner_says():
    # the lattice's backward move: yaw 0 while x decreases; no turn to face the other way
    back = np.array([[1.0, 1.0, 0.0], [0.9, 1.0, 0.0]])
    poses = bench_plan.densify(back, RES, WAFFLE, backward=[False, True])
    assert np.all(poses[:, 2] == 0.0) and len(poses) == 5               # 0.1 m in 0.025 m steps
    # unflagged, the same poses are driven forward: a half turn, the drive, a half turn back
    poses = bench_plan.densify(back, RES, WAFFLE)
    assert np.abs(poses[:, 2]).max() >= math.pi - 1e-9 and math.cos(poses[-1, 2]) == pytest.approx(1.0)
    # a pose that faces across its segment turns to it, drives, and turns to the next pose's yaw
    poses = bench_plan.densify(np.array([[1.0, 1.0, 0.0], [1.0, 1.1, 0.0]]), RES, WAFFLE)
    assert poses[:, 2].max() == pytest.approx(math.pi / 2) and poses[-1, 2] == pytest.approx(0.0)


def test_densify_turns_the_short_way_across_pi():
    # yaw 3.0 -> -3.0 is a 0.28 rad turn, not 6 rad; then a drive west (pi) turns 0.14 rad more
    poses = bench_plan.densify(np.array([[1.0, 1.0, 3.0], [1.0, 1.0, -3.0], [0.9, 1.0, -3.0]]), RES, WAFFLE)
    assert np.abs(np.diff(poses[:, 2])).sum() == pytest.approx((2 * math.pi - 6.0) + 2 * (math.pi - 3.0))


def test_densify_spacing():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    poses = bench_plan.densify(path, RES, WAFFLE)
    step = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    turn = np.abs(np.diff(poses[:, 2]))
    assert step.max() <= 0.5 * RES + 1e-12 and turn.max() * WAFFLE.radius_m <= 0.5 * RES + 1e-12
    assert poses[0].tolist() == [0.0, 0.0, 0.0] and poses[-1].tolist() == pytest.approx([1.0, 1.0, math.pi / 2])
    assert ((poses[:, 0] == 1.0) & (poses[:, 1] == 0.0)).sum() >= 3    # the turn at the corner


def test_rows_and_plan_json_keys(pairs):
    occ = two_rooms()
    keys = bench_plan.planner_keys(["lattice", "astar_shortcut", "rrt_seed003"])
    rows = []
    for robot in (WAFFLE, BURGER):
        for pair in pairs[robot.name][:2]:
            rows += bench_plan.run_pair("two_rooms", True, robot, occ, RES, ORIGIN, pair, keys)
    assert len(rows) == 2 * 2 * 3
    figures = bench_plan.summarise(rows, real_worlds={"two_rooms"})
    for k in ("min_success_rate", "best_ompl_length_ratio_0_2s", "astar_shortcut_length_ratio",
              "lattice_p95_ms_real_maps"):
        assert k in figures
    for planner in ("lattice", "astar_shortcut", "rrt_seed003"):
        for f in bench_plan.FIGURES:
            assert f"{f}_{planner}" in figures
    assert figures["success_rate_lattice"] == 1.0 and figures["length_ratio_lattice"] >= 1.0
    assert figures["min_success_rate_planners"] == ["lattice", "astar_shortcut"]
    assert figures["lattice_p95_ms_real_maps"] > 0
    assert figures["best_ompl_length_ratio_0_2s"] is None        # no OMPL planner ran
    json.dumps(figures)                                          # plan.json can be written


def test_headline_figures_worked_by_hand():
    def row(planner, success, ratio=1.0, time_ms=1.0, robot="turtlebot3_burger", world="w"):
        return dict(world=world, robot=robot, pair=0, planner=planner, found=success, success=success, clear=success,
                    time_ms=time_ms, length_ratio=ratio, clearance_m=0.1, error="" if success else "no path")
    rows = ([row("lattice", True, 1.1, t) for t in (10.0, 20.0, 30.0, 40.0)]
            + [row("ompl_rrtstar_0_2s", s, 1.2) for s in (True, True, True, False)]
            + [row("ompl_bitstar_0_2s", True, 1.05)] * 4
            + [row("ompl_bitstar_0_05s", False)] * 4                # tier 0_05s: reported apart
            + [row("rrt_seed003", False)] * 4)                      # the baseline: apart
    f = bench_plan.summarise(rows, real_worlds={"w"})
    assert f["min_success_rate"] == 0.75                            # rrtstar: 3 of 4
    assert f["best_ompl_length_ratio_0_2s"] == pytest.approx(1.05)  # bitstar's, not rrtstar's 1.2
    assert f["lattice_p95_ms_real_maps"] == pytest.approx(38.5)     # 30 + 0.85 x (40 - 30)
    assert f["time_ms_median_lattice"] == 25.0
    assert f["astar_shortcut_length_ratio"] is None
    assert f["failure_reasons"]["ompl_rrtstar_0_2s"] == {"no path": 1}
    refused = dict(row("rrt_seed003", False), error="plan_rrt_seed003 (...): rrt_seed003: goal (3.0, 4.0) (x, y "
                                                    "cells): its 8 x 8 cell hit-box meets an obstacle or the grid's edge")
    collided = dict(row("lattice", False), found=True)
    assert [bench_plan.failure_reason(r) for r in (refused, collided, row("lattice", False))] == \
        ["refused", "collision", "no path"]
    assert bench_plan.planner_keys(["rrtconnect"]) == [("ompl_rrtconnect_0_05s", "rrtconnect", "0_05s"),
                                                       ("ompl_rrtconnect_0_2s", "rrtconnect", "0_2s")]
