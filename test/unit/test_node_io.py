"""What the thin nodes hand to ros/ and to the core (no master): log levels, the navigator's
messages and loop line, the explorer's parameters and message conversions."""
import logging

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import Quaternion

from turtlebot_recon.config import ConfigError
from turtlebot_recon.evaluation.evaluator import EvaluatorSettings, end_reason
from turtlebot_recon.exploration.node_settings import explorer_params
from turtlebot_recon.msg import TagDetection, TagDetectionArray
from turtlebot_recon.paths import SHARE_DIR
from turtlebot_recon.planning.navigation import loop_summary
from turtlebot_recon.ros import convert, explore_msgs, navigator_msgs
from turtlebot_recon.ros.latest import Latest
from turtlebot_recon.ros.log import ros_log


def test_core_log_lines_keep_their_level_on_rosout(caplog):
    with caplog.at_level(logging.DEBUG, logger="rosout"):
        for level in (logging.DEBUG, logging.INFO, logging.WARNING, logging.ERROR):
            ros_log(level, "explorer: line %d", level)
    got = [(r.levelno, r.getMessage()) for r in caplog.records if r.name == "rosout"]
    assert got == [(lv, f"explorer: line {lv}") for lv in (logging.DEBUG, logging.INFO, logging.WARNING,
                                                             logging.ERROR)]


def test_loop_summary_reads_the_mean_rate_and_leaves_out_pauses():
    # steps 0.04 and 0.06 s apart (a 0.05 s sim-time timer on a 0.02 s clock): 20 Hz by the
    # mean period, where the median (either) would read 25 or 16.7 Hz; the 5 s pause between
    # two goals is not a period
    t = np.cumsum([0.0] + [0.04, 0.06] * 10)
    t = np.concatenate([t, t[-1] + 5.0 + t])
    ms = np.full(t.size, 2.0)
    ms[-1] = 9.0
    line = loop_summary(t, ms)
    assert line.startswith(f"control loop over {t.size} steps: 20.0 Hz in sim time")
    assert "max 9.0 ms" in line and "median 2.0 ms" in line
    assert loop_summary(np.array([1.0]), np.array([1.0])) is None
    assert loop_summary(np.array([1.0, 3.0]), np.array([1.0, 1.0])) is None       # only a pause


def test_goal_yaw_none_for_the_all_zero_quaternion():
    assert navigator_msgs.goal_yaw(Quaternion(0.0, 0.0, 0.0, 0.0)) is None       # any final heading
    assert navigator_msgs.goal_yaw(convert.yaw_to_quaternion(1.2)) == pytest.approx(1.2)


def test_path_message_keeps_the_points_in_order():
    xy = np.array([[0.0, 0.0], [0.5, 0.1], [1.0, 0.3]])
    m = navigator_msgs.path(xy, "odom", convert.stamp(3.0))
    assert m.header.frame_id == "odom" and len(m.poses) == 3
    assert [(p.pose.position.x, p.pose.position.y) for p in m.poses] == [tuple(p) for p in xy]


def test_glimpses_of_unconfirmed_tags():
    m = TagDetectionArray()
    m.header.stamp = convert.stamp(7.5)
    d = TagDetection()
    d.family, d.id = "tag36h11", 4
    d.pose.pose.position.x, d.pose.pose.position.y = 1.0, -2.0
    d.pose.pose.orientation = Quaternion(0.5, 0.5, 0.5, 0.5)        # z axis along map +x
    m.detections.append(d)
    (g,) = explore_msgs.glimpses(m)
    assert (g.family, g.id, g.x, g.y, g.stamp_s) == ("tag36h11", 4, 1.0, -2.0, 7.5)
    assert g.yaw == pytest.approx(0.0, abs=1e-9)


def test_latest_converts_each_message_once():
    calls = []
    latest = Latest(lambda m: calls.append(m) or m * 2)
    assert latest.get() is None
    latest(3)
    assert latest.get() == 6 and latest.get() == 6 and calls == [3]
    latest(4)
    assert latest.get() == 8 and calls == [3, 4]


def explorer_yaml():
    params = yaml.safe_load((SHARE_DIR / "config" / "explorer.yaml").read_text())
    params["robot"] = "turtlebot3_burger"
    return params


def test_explorer_params_read_every_block_and_warn_when_one_is_missing():
    params = explorer_yaml()
    params["supervisor"] = {"spin_angle_deg": 90.0}
    params["lattice"] = yaml.safe_load((SHARE_DIR / "config" / "lattice.yaml").read_text())
    params["frontiers"] = dict(params.get("frontiers") or {}, min_size_cells=7)
    warned = []
    p = explorer_params(params, "/explorer", warned.append)
    assert warned == []
    assert p.node.robot == "turtlebot3_burger" and p.supervisor.spin_angle_deg == 90.0
    assert p.frontiers.min_size_cells == 7 and p.strategy.name == params.get("strategy", p.strategy.name)
    del params["supervisor"]
    explorer_params(params, "/explorer", warned.append)
    assert len(warned) == 1 and "~supervisor" in warned[0]
    params["cycle_period_s"] = -1.0
    with pytest.raises(ConfigError, match="cycle_period_s"):
        explorer_params(params, "/explorer", warned.append)


def test_evaluator_end_rule_stop_coverage_first_then_the_budget():
    s = EvaluatorSettings(world="house", robot="turtlebot3_burger", budget_s=100.0, stop_coverage=0.9)
    assert end_reason(s, 50.0, 0.5) is None
    assert end_reason(s, 50.0, 0.95) == "coverage 95.0 % reached stop_coverage 0.9"
    assert end_reason(s, 100.0, None) == "time budget 100 s spent"       # no map: the budget still ends it
    assert end_reason(EvaluatorSettings(world="house", robot="turtlebot3_burger", budget_s=0.0), 1e6, 1.0) is None
