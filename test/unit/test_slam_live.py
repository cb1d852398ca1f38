"""The live SLAM node's policy (slam/live.py): scan / gyro synchronisation, the tag range gate,
the clock-jump reset, and the sessions that put them in front of the SLAM and localisation cores."""
import math

import numpy as np
import pytest

from turtlebot_recon.evaluation.trajectory_metrics import read_tum
from turtlebot_recon.slam.live import (ClockWatch, GyroQueue, LiveLocalization, LiveSlam, PathUpdate, pose_std,
                                       tag_in_base, tag_plausible)
from turtlebot_recon.slam.localization import LocalizationSettings, Localizer
from turtlebot_recon.slam.slam import Slam, SlamSettings


def room_points(half_m: float = 1.95, step_m: float = 0.05) -> np.ndarray:
    """The inner faces of a square room (half-width ``half_m``) seen from its centre, base frame."""
    s = np.arange(-half_m, half_m, step_m)
    edge = np.full_like(s, half_m)
    return np.vstack([np.column_stack([s, edge]), np.column_stack([s, -edge]),
                      np.column_stack([edge, s]), np.column_stack([-edge, s])])


def test_a_scan_waits_for_the_gyro_while_it_talks():
    q = GyroQueue(imu_silent_s=0.5, max_pending=3)
    assert q.add_scan(1.0, "a") == [(1.0, "a")]        # no IMU yet: it goes at once
    assert q.add_imu(1.05) == []
    assert q.add_scan(1.2, "b") == []                  # the IMU spoke 0.15 s before it: wait ...
    assert q.add_imu(1.15) == []                       # ... for the samples up to its stamp ...
    assert q.add_imu(1.2) == [(1.2, "b")]              # ... which are in now
    # the IMU stalls at 1.2 s: scans within 0.5 s of it wait, but never more than 3
    assert [q.add_scan(t, n) for t, n in ((1.3, "c"), (1.4, "d"), (1.5, "e"))] == [[], [], []]
    assert q.add_scan(1.6, "f") == [(1.3, "c")]        # a 4th waiting: the oldest goes
    # 1.75 - 0.5 > 1.2: the IMU counts as off, everything goes, oldest first
    assert q.add_scan(1.75, "g") == [(1.4, "d"), (1.5, "e"), (1.6, "f"), (1.75, "g")]
    q.add_imu(2.0)
    q.add_scan(2.1, "h")
    q.clear()                                          # a clock jump: nothing waits, no IMU known
    assert not q.pending and q.add_scan(0.1, "i") == [(0.1, "i")]


def test_the_clock_going_back_more_than_a_second_is_a_jump():
    c = ClockWatch(jump_back_s=1.0)
    assert not c.jumped_back(10.0)                     # the first reading
    assert not c.jumped_back(9.5)                      # 0.5 s back: jitter, not a new run
    assert c.jumped_back(8.4)                          # 1.1 s back from 9.5 s
    assert not c.jumped_back(8.5)


def test_tags_move_into_the_base_frame_and_absurd_ones_fail_the_gate():
    # camera frame turned 90 degrees about z, 0.1 m ahead of and 0.2 m above the base
    base_from_camera = np.array([[0.0, -1.0, 0.0, 0.1], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.2], [0, 0, 0, 1.0]])
    cov6 = np.diag([1.0, 4.0, 9.0, 0.1, 0.1, 0.1]).ravel().tolist()
    xyz, cov = tag_in_base((1.0, 0.0, 0.5), cov6, base_from_camera)
    np.testing.assert_allclose(xyz, [0.1, 1.0, 0.7])   # R (1, 0, 0.5) = (0, 1, 0.5), plus the offset
    np.testing.assert_allclose(cov, np.diag([4.0, 1.0, 9.0]))   # x and y variances swap
    ok = np.eye(3)
    assert tag_plausible(np.array([7.9, 0.0, 0.0]), ok) and tag_plausible(np.array([5.0, 6.0, 3.0]), ok)  # 7.8 m
    assert not tag_plausible(np.array([8.1, 0.0, 0.0]), ok)
    assert not tag_plausible(np.array([6.0, 6.0, 0.0]), ok)                    # 8.5 m
    assert not tag_plausible(np.array([1.0, np.nan, 0.0]), ok)
    assert not tag_plausible(np.array([1.0, 0.0, 0.0]), np.diag([np.inf, 1.0, 1.0]))


def test_pose_std_of_rviz_covariance():
    cov = np.zeros(36)
    assert pose_std(cov) == (None, None)               # rviz's estimate without spread: the defaults
    cov[0], cov[7], cov[35] = 0.04, 0.09, 0.01
    assert pose_std(cov) == (pytest.approx(0.3), pytest.approx(0.1))   # the larger of x's and y's


def test_live_slam_holds_a_scan_for_the_gyro_publishes_saves_and_resets(tmp_path):
    live = LiveSlam(Slam(SlamSettings(), wheel_separation_m=0.16))
    with pytest.raises(OSError, match="no keyframe yet"):
        live.save(str(tmp_path / "early"), "test")
    assert not live.clock(0.1)
    assert live.add_imu(0.0, 0.0) is None
    assert live.add_scan(0.1, room_points(), (0.0, 0.0, 0.0)) is None   # the IMU talks: waits for it
    assert live.map_to_odom is None                                     # no map -> odom before a keyframe
    update = live.add_imu(0.12, 0.0)
    assert isinstance(update, PathUpdate) and update.stamps == [0.1] and update.loops == []
    np.testing.assert_allclose(update.poses, [[0.0, 0.0, 0.0]])
    assert live.map_to_odom == (0.0, 0.0, 0.0)
    line = live.status_line()            # no gyro step yet: no bias or scale to report
    assert line.startswith("1 keyframes (0 matched") and "gyro" not in line, line
    assert live.add_tag(0.15, "tag36h11:3", np.array([1.0, 0.5, 0.3]), np.eye(3) * 0.01, (0.0, 0.0, 0.0)) is None
    line = live.save(str(tmp_path / "out"), "test")
    assert line.startswith(f"graph and trajectories saved (test) to {tmp_path / 'out'}")
    assert (tmp_path / "out" / "graph.g2o").stat().st_size > 0
    assert read_tum(tmp_path / "out" / "trajectory.tum").shape[0] == 1
    assert read_tum(tmp_path / "out" / "odometry.tum").shape[0] == 1
    # the clock goes back: the session forgets the graph, the queue, the odometry and map -> odom
    assert not live.clock(5.0)
    live.add_imu(5.0, 0.0)
    live.add_scan(5.1, room_points(), (0.3, 0.0, 0.0))                  # waiting for the gyro
    assert live.clock(3.0)
    assert live.map_to_odom is None and live.odom_poses == [] and not live.queue.pending
    assert live.core.graph is None and live.core.counts["resets"] == 1
    assert "state cleared: time jumped back to 3.00 s" in live.take_events()
    assert live.add_tag(3.1, "tag36h11:3", np.zeros(3), np.eye(3), (0.0, 0.0, 0.0)) == "no keyframe yet"


def test_live_localization_publishes_every_match_and_takes_rviz_poses(tmp_path):
    occ = np.full((100, 100), -1, np.int8)             # 0.05 m cells, a 4 m room around the origin
    occ[10:90, 10:90] = 100
    occ[11:89, 11:89] = 0
    core = Localizer(LocalizationSettings(), occ, 0.05, (-2.5, -2.5), wheel_separation_m=0.16)
    live = LiveLocalization(core)
    cov = np.zeros(36)
    cov[0] = cov[7] = 0.04
    live.set_pose((0.0, 0.0, 0.0), cov)
    np.testing.assert_allclose(np.diag(core.cov)[:2], [0.04, 0.04])
    with pytest.raises(OSError, match="no scan matched yet"):
        live.save(str(tmp_path / "early"), "test")
    update = live.add_scan(1.0, room_points(), (0.0, 0.0, 0.0))    # no IMU in this mode: at once
    assert update.stamps == [1.0] and update.loops == [] and update.landmarks == {}
    assert math.hypot(*update.poses[0][:2]) < 0.05 and live.map_to_odom is not None
    assert live.add_scan(1.2, room_points(), (0.01, 0.0, 0.0)) is None   # too close for an update
    assert live.save(str(tmp_path / "out"), "test").startswith("localisation trajectory saved (test)")
    assert read_tum(tmp_path / "out" / "trajectory.tum").shape[0] == 1
    assert read_tum(tmp_path / "out" / "odometry.tum").shape[0] == 2
