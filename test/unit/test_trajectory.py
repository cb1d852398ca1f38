"""The driven-path core (turtlebot_recon.trajectory) and its settings (YAML keys: test_config)."""
import math

import pytest

from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.trajectory import Trajectory, TrajectorySettings


def test_keeps_a_pose_only_after_min_step():
    tr = Trajectory(TrajectorySettings(min_step_m=0.05))
    assert tr.add(0.0, 0.0, 0.0, 0.0)                 # the first pose is always kept
    assert not tr.add(0.2, 0.03, 0.04 - 1e-6, 0.0)    # 0.05 m - a hair: jitter, dropped
    assert not tr.add(0.4, 0.0, 0.0, 1.5)             # turning in place adds nothing
    assert tr.add(0.6, 0.03, 0.04, 0.0)               # 3-4-5 triangle: exactly 0.05 m
    assert tr.add(0.8, 0.03, 0.14, 0.0)               # + 0.10 m
    assert [p[1:3] for p in tr.poses] == [(0.0, 0.0), (0.03, 0.04), (0.03, 0.14)]
    assert tr.length_m == pytest.approx(0.15)         # 0.05 + 0.10
    assert tr.version == 3


def test_time_going_back_starts_a_new_path():
    tr = Trajectory(TrajectorySettings())
    tr.add(5.0, 0.0, 0.0, 0.0)
    tr.add(6.0, 1.0, 0.0, 0.0)
    assert tr.add(6.0, 2.0, 0.0, 0.0)                 # same stamp (TF not updated yet): fine
    assert tr.add(1.0, 7.0, 7.0, 0.0)                 # simulator restarted: a new path
    assert (tr.poses, tr.length_m, tr.resets) == ([(1.0, 7.0, 7.0, 0.0)], 0.0, 1)


def test_thinning_keeps_first_newest_and_the_shape():
    tr = Trajectory(TrajectorySettings(min_step_m=0.05, max_poses=10))
    for i in range(11):                               # 11 poses 0.1 m apart on a line
        tr.add(float(i), 0.1 * i, 0.0, 0.0)
    # 11 > 10: keep poses 0, 2, 4, 6, 8 of the older ten, and the newest (10)
    assert [round(p[1], 3) for p in tr.poses] == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert tr.length_m == pytest.approx(1.0)          # the length driven is not thinned
    for i in range(11, 16):                           # 6 + 5 = 11 > 10 again
        tr.add(float(i), 0.1 * i, 0.0, 0.0)
    assert len(tr.poses) <= 10 and tr.poses[0][1] == 0.0 and tr.poses[-1][1] == pytest.approx(1.5)


def test_bad_input_is_refused_and_leaves_the_path_alone():
    tr = Trajectory(TrajectorySettings())
    tr.add(0.0, 0.0, 0.0, 0.0)
    for bad in ((1.0, math.nan, 0.0, 0.0), (1.0, 0.0, math.inf, 0.0), (math.nan, 1.0, 1.0, 0.0)):
        with pytest.raises(ValueError, match="non-finite"):
            tr.add(*bad)
    assert len(tr.poses) == 1 and tr.version == 1


def test_settings_are_validated():
    with pytest.raises(ConfigError, match="src/min_step_m: must be a positive number"):
        from_dict(TrajectorySettings, {"min_step_m": 0.0}, "src")
    with pytest.raises(ConfigError, match="src/max_poses: must be an integer >= 2"):
        from_dict(TrajectorySettings, {"max_poses": 1}, "src")
