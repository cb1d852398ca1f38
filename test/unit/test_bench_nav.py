"""bench-nav's fixed pairs (test/benchmarks/nav_pairs.yaml) and its command statistics
(test/benchmarks/bench_nav.py): the data the navigation table rests on."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_nav  # noqa: E402

from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH  # noqa: E402
from turtlebot_recon.robot import footprint_args, load_robot  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402

PAIRS = yaml.safe_load(bench_nav.PAIRS_FILE.read_text())


@pytest.mark.parametrize("world_name", ["house", "office", "maze"])
def test_each_world_has_30_pairs_whose_starts_fit_and_goals_are_far(world_name):
    entry = PAIRS["worlds"][world_name]
    assert entry["robot"] == bench_nav.WORLD_ROBOTS[world_name]
    pairs = entry["pairs"]
    assert len(pairs) >= 30
    world, robot = load_world(world_name), load_robot(entry["robot"])
    occ = world.occupancy()
    starts = np.array([p["start"] for p in pairs], float)
    # every start: the body clear of walls (the circumscribed disc's spare, any heading)
    clearance = _native.body_field_clearance(occ, world.resolution, world.origin, starts, max_m=1.0,
                                             **footprint_args(robot), spacing_m=0.05,
                                             occupied_threshold=OCCUPIED_THRESH)
    assert clearance.min() > 0.05
    for p in pairs:
        assert math.dist(p["start"][:2], p["goal"]) >= bench_nav.MIN_PAIR_DISTANCE_M
        assert world.is_free(*p["goal"])
        assert p["plan_m"] >= math.dist(p["start"][:2], p["goal"]) - 0.1   # a plan is no shorter than the line
    assert len({(tuple(p["start"]), tuple(p["goal"])) for p in pairs}) == len(pairs)


def test_pairs_are_reproducible_from_their_seed():
    again = bench_nav.make_pairs("house", "turtlebot3_waffle_pi", 3, PAIRS["seed"])
    assert again == PAIRS["worlds"]["house"]["pairs"][:3]


def test_command_stats_count_stops_reversals_and_jerk():
    dt = 0.1
    v = [0.0, 0.1, 0.2, 0.2, 0.0, 0.0, 0.2, 0.2, -0.1, -0.1, 0.2, 0.0]   # a stop, then back and forth, arrive
    stats = bench_nav.command_stats(np.column_stack([v, np.zeros(len(v))]), dt)
    assert stats["stops"] == 1          # 0.2 -> 0.0 mid-way; the final stop is the arrival
    assert stats["reversals"] == 2      # forward -> backward -> forward
    smooth = bench_nav.command_stats(np.column_stack([np.linspace(0, 0.2, 12), np.zeros(12)]), dt)
    assert smooth["stops"] == 0 and smooth["reversals"] == 0 and smooth["jerk"] == pytest.approx(0.0, abs=1e-9)
    assert stats["jerk"] > 10.0
