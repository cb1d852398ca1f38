"""Sensor logs: CARMEN and rosbag readers and writers, and the simulator's recorded runs."""
import math
import subprocess
import sys

import numpy as np
import pytest

from turtlebot_recon.evaluation.trajectory_metrics import read_tum
from turtlebot_recon.sim.recorder import record_run
from turtlebot_recon.slam.logs import (CarmenReader, ImuRecord, LaserRecord, LogError, LogStats, OdomRecord,
                                       TimeJump, flaser_geometry, in_stamp_order, write_carmen)

rosbag = pytest.importorskip("rosbag")   # Debian's python3-rosbag (tools/apt-packages.txt)
from turtlebot_recon.ros.bags import BagReader, write_rosbag  # noqa: E402  (the ROS layer: needs rosbag)


def laser(t, ranges, odom=(1.0, 2.0, 0.5), laser_pose=(1.1, 2.0, 0.5), angle_min=-1.0, inc=0.25,
          range_min=0.12, range_max=3.5):
    return LaserRecord(t, np.asarray(ranges, np.float32), angle_min, inc, range_min, range_max, odom, laser_pose)


def same_laser(a, b):
    assert (a.stamp_s, a.angle_min, a.angle_increment, a.range_max) == (b.stamp_s, b.angle_min, b.angle_increment,
                                                                       b.range_max)
    assert a.odom_pose == b.odom_pose and a.laser_pose == b.laser_pose
    np.testing.assert_array_equal(a.ranges, b.ranges)


def test_carmen_round_trip(tmp_path):
    r = np.float32([0.5, 1.234567, 3.4999, np.inf, 0.3333333, 2.0, 0.13])
    flaser_angles = flaser_geometry(180)
    records = [laser(10.0, r),
               OdomRecord(10.02, 1.0, 2.0, 0.5, 0.2, -0.1),
               laser(10.2, r[::-1], odom=None, laser_pose=None),     # no odometry: RAWLASER1
               laser(10.4, np.linspace(0.2, 3.0, 180), angle_min=flaser_angles[0], inc=flaser_angles[1],
                     range_max=81.9, laser_pose=(1.0, 2.0, 0.5)),    # FLASER geometry
               OdomRecord(1e9 + 0.123456, -3.25, 1e-7, -math.pi, 0.0, 0.0)]
    path = tmp_path / "a.clf"
    assert write_carmen(path, records, flaser=True) == 5
    text = path.read_text()
    assert [ln.split()[0] for ln in text.splitlines() if not ln.startswith("#")] == [
        "ROBOTLASER1", "ODOM", "RAWLASER1", "FLASER", "ODOM"]
    back = list(CarmenReader(path, range_min_m=0.12))
    assert len(back) == len(records)
    for a, b in zip(records, back):
        if isinstance(a, OdomRecord):
            assert a == b                                    # exact: shortest round-trip text
        else:
            same_laser(a, b)
            assert b.range_min == 0.12 and b.ranges.dtype == np.float32


def test_carmen_invalid_ranges_become_no_return(tmp_path):
    # NaN, 0 (an LDS-01 dropout), below range_min, beyond range_max: all "no return" (+inf)
    rec = laser(1.0, [np.nan, 0.0, 0.05, 4.0, -np.inf, 1.5, 3.5])
    write_carmen(tmp_path / "b.clf", [rec])
    (back,) = CarmenReader(tmp_path / "b.clf")
    np.testing.assert_array_equal(back.ranges[:5], np.inf)
    assert back.ranges[5] == np.float32(1.5)
    assert 3.499 < back.ranges[6] < 3.5     # a valid reading at range_max stays valid, just below it
    # a maximum range float32 cannot hold: "no return" is still written as that very number
    rec = laser(1.0, [np.nan, 3.1234567], range_max=3.123456789)
    write_carmen(tmp_path / "c.clf", [rec])
    (back,) = CarmenReader(tmp_path / "c.clf")
    assert back.range_max == 3.123456789 and np.isinf(back.ranges[0]) and float(back.ranges[1]) < 3.123456789


def flaser_line(n, ts, value="2.5"):
    return f"FLASER {n} " + " ".join([value] * n) + f" 0.1 0.2 0.3 1.0 2.0 0.05 {ts} nohost 0.1"


SNIPPET = "\n".join([
    "# CARMEN Logfile",
    "# file format is one message per line",
    "PARAM robot_frontlaser_offset 0.0 975016313.76 nohost 0.0",
    "ODOM 0.000000 0.000000 0.000000 0.000000 0.000000 0.000000 975016313.760 nohost 0.040",
    flaser_line(180, "975016313.900"),
    # ROBOTLASER1 of CARMEN 0.7 (remissions, turn_axis), 5 beams, 81.91 = no return
    "ROBOTLASER1 0 -1.570796 3.141593 0.785398 81.910000 0.010000 0 5 1.000 2.000 81.910 3.000 0.000 "
    "0 0.250000 0.000000 0.100000 0.200000 0.000000 0.100000 0.300000 -0.100000 0.0 0.0 0.0 "
    "975016314.000 nohost 0.3",
    "ROBOTLASER1 0 -1.570796 3.141593 0.785398 81.910000 0.010000 0 5 1.000 2.000",      # truncated
    "SYNC tag1 975016314.1 nohost 0.4",
    "@@@ \x00\x07 garbage that is no message",                                             # garbage
    "ODOM 0.1 0.0 0.1 0.2 0.0 0.0 975016313.800 nohost 0.5",     # logged late: earlier stamp
    # the older ROBOTLASER1 layout: no remissions, no turn_axis
    "ROBOTLASER1 0 -0.5 1.0 0.5 4.0 0.01 0 3 1.0 2.0 3.0 0.5 0.6 0.7 0.4 0.6 0.7 0.0 0.0 0.0 0.0 "
    "975016314.200 nohost 0.6",
    "ODOM 0.2 0.0 abc 0.2 0.0 0.0 975016314.300 nohost 0.7",                                # malformed
    flaser_line(180, "975016314.4")[:300],                                                   # cut short
])


def test_carmen_snippet(tmp_path):
    path = tmp_path / "snippet.clf"
    path.write_text(SNIPPET)
    reader = CarmenReader(path)
    recs = list(reader)
    # kept: 2 ODOM, 1 FLASER, 2 ROBOTLASER1, in time order (the late ODOM moved before the FLASER)
    assert [type(r).__name__ for r in recs] == ["OdomRecord", "OdomRecord", "LaserRecord", "LaserRecord",
                                                "LaserRecord"]
    assert [r.stamp_s for r in recs] == sorted(r.stamp_s for r in recs)
    assert recs[1] == OdomRecord(975016313.8, 0.1, 0.0, 0.1, 0.2, 0.0)
    fl, rl, old = recs[2], recs[3], recs[4]
    # FLASER: 180 beams, -90 deg in 1 deg steps; first pose the laser's, second the robot's
    assert len(fl.ranges) == 180 and fl.angle_min == pytest.approx(-math.pi / 2)
    assert fl.angle_increment == pytest.approx(math.radians(1.0))
    assert fl.laser_pose == (0.1, 0.2, 0.3) and fl.odom_pose == (1.0, 2.0, 0.05)
    # ROBOTLASER1: its own geometry; 81.91 (the maximum range) is no return -> inf, 0.0 -> NaN
    assert (rl.angle_min, rl.angle_increment, rl.range_max) == (-1.570796, 0.785398, 81.91)
    np.testing.assert_array_equal(rl.ranges, np.float32([1.0, 2.0, np.inf, 3.0, np.nan]))
    assert rl.laser_pose == (0.25, 0.0, 0.1) and rl.odom_pose == (0.2, 0.0, 0.1)
    assert old.odom_pose == (0.4, 0.6, 0.7) and len(old.ranges) == 3
    s = reader.stats
    assert s.skipped == {"truncated": 2, "malformed": 2}
    assert s.ignored == {"comment": 2, "PARAM": 1, "SYNC": 1}
    assert s.reordered == 1
    summary = reader.summary()
    assert "2 truncated (first line 7" in summary and "2 malformed (first line 9" in summary
    assert "1 PARAM" in summary and "1 out of time order" in summary


def test_missing_files_and_non_bags(tmp_path):
    with pytest.raises(LogError, match="no such file"):
        CarmenReader(tmp_path / "nope.clf")
    (tmp_path / "text.bag").write_text("not a bag\n")
    with pytest.raises(LogError, match="not a readable rosbag"):
        BagReader(tmp_path / "text.bag")
    write_rosbag(tmp_path / "odom_only.bag", [OdomRecord(1.0, 0, 0, 0, 0, 0)])
    with pytest.raises(LogError, match="no /scan in the bag"):
        BagReader(tmp_path / "odom_only.bag")


def test_bag_topics_recorded_seconds_apart_merge_in_stamp_order(tmp_path):
    """rosbag record under load (or a simulation faster than real time) writes one topic's
    messages seconds after another's: a lag is not a time jump, and nothing is lost. A looping
    bag's jump, seen first on one topic, is one TimeJump; the other topics' messages stamped
    before their own jump, recorded after it, are skipped."""
    scans = [laser(t, [1.0, 2.0], odom=None, laser_pose=None) for t in np.arange(1.0, 7.01, 0.2)]
    odoms = [OdomRecord(t, t, 0.0, 0.0, 0.1, 0.0) for t in np.arange(1.0, 7.01, 0.03)]
    imus = [ImuRecord(t, 0.0) for t in np.arange(1.0, 7.01, 0.02)]
    # recording order: the odometry 2 s behind the scans, the IMU 1.5 s behind
    order = sorted([(r.stamp_s, r) for r in scans] + [(r.stamp_s + 2.0, r) for r in odoms] +
                   [(r.stamp_s + 1.5, r) for r in imus], key=lambda p: p[0])
    recs = [r for _, r in order]
    # then the bag loops: the scans go back first, odometry still arriving from the first run
    recs += [laser(t, [1.0, 2.0], odom=None, laser_pose=None) for t in (1.0, 1.2)]
    recs += [OdomRecord(7.05, 0, 0, 0, 0, 0), OdomRecord(1.0, 0, 0, 0, 0, 0), OdomRecord(1.03, 0, 0, 0, 0, 0)]
    write_rosbag(tmp_path / "lag.bag", recs)
    reader = BagReader(tmp_path / "lag.bag")
    back = list(reader)
    jumps = [i for i, r in enumerate(back) if isinstance(r, TimeJump)]
    assert len(jumps) == 1
    first_run, second_run = back[:jumps[0]], back[jumps[0] + 1:]
    assert [r.stamp_s for r in first_run] == sorted(r.stamp_s for r in first_run)
    kinds = [type(r).__name__ for r in first_run]
    assert (kinds.count("LaserRecord"), kinds.count("OdomRecord"), kinds.count("ImuRecord")) == \
        (len(scans), len(odoms), len(imus))                      # nothing lost to the lag
    assert [round(r.stamp_s, 2) for r in second_run] == [1.0, 1.0, 1.03, 1.2]
    assert reader.stats.skipped == {"before the jump": 1}       # odometry 7.05, from the first run


def test_bag_round_trip_reorder_late_and_time_jump(tmp_path):
    scan = [1.0, np.nan, 0.0, 2.5]
    recs = [laser(t, scan, odom=None, laser_pose=None) for t in (10.0, 10.2, 10.4)]
    recs += [OdomRecord(10.1, 1.0, 2.0, 3.0, 0.2, 0.1), ImuRecord(10.05, 0.3)]
    recs.sort(key=lambda r: r.stamp_s)
    recs.insert(4, OdomRecord(10.15, 1.0, 2.0, 3.0, 0.2, 0.1))   # written after 10.2 s: re-sorted
    recs += [laser(t, scan, odom=None, laser_pose=None) for t in np.arange(10.6, 12.05, 0.2)]
    recs.append(OdomRecord(11.1, 0, 0, 0, 0, 0))                 # the odometry's queue lagged 0.9 s: kept
    recs.append(OdomRecord(11.05, 0, 0, 0, 0, 0))                # older than its own topic's last: late
    recs += [laser(t, scan, odom=None, laser_pose=None) for t in (2.0, 2.2)]   # the bag looped
    write_rosbag(tmp_path / "a.bag", recs)
    reader = BagReader(tmp_path / "a.bag")
    back = list(reader)
    stamps = [round(r.stamp_s, 3) for r in back]
    jump = next(i for i, r in enumerate(back) if isinstance(r, TimeJump))
    assert back[jump] == TimeJump(2.0, pytest.approx(12.0))
    assert stamps[:jump] == sorted(stamps[:jump])
    assert stamps[:5] == [10.0, 10.05, 10.1, 10.15, 10.2]
    assert [r.stamp_s for r in back[jump + 1:]] == [2.0, pytest.approx(2.2)]
    assert [r.stamp_s for r in back if isinstance(r, OdomRecord)] == [10.1, 10.15, 11.1]
    assert reader.stats.skipped == {"late": 1} and reader.stats.reordered == 2
    assert "time went back 1 time(s) (first from 12.000 s to 2.000 s)" in reader.summary()
    odom = [r for r in back if isinstance(r, OdomRecord)][0]
    assert (odom.x, odom.y, odom.v, odom.w) == (1.0, 2.0, 0.2, 0.1) and odom.yaw == pytest.approx(3.0)
    first = back[0]
    np.testing.assert_array_equal(first.ranges, np.float32(scan))   # raw values, NaN and 0.0 kept
    assert first.odom_pose is None and first.range_max == 3.5
    assert first.range_min == pytest.approx(0.12) and (first.angle_min, first.angle_increment) == (-1.0, 0.25)
    assert [r.yaw_rate for r in back if isinstance(r, ImuRecord)] == [0.3]


def test_core_reads_carmen_without_ros(tmp_path):
    """The core's logs, the offline pipeline and the recorder import and read CARMEN without ROS;
    the bag reader, ROS's, says what is missing."""
    write_carmen(tmp_path / "a.clf", [OdomRecord(1.0, 0, 0, 0, 0, 0)])
    code = ("import sys\n"
            "for m in ('rosbag', 'genpy', 'rospy', 'sensor_msgs', 'nav_msgs'):\n"
            "    sys.modules[m] = None                    # as on a machine without ROS\n"
            "import turtlebot_recon.slam.logs as logs, turtlebot_recon.slam.offline, turtlebot_recon.sim.recorder\n"
            "print(len(list(logs.CarmenReader(sys.argv[1] + '/a.clf'))))\n"
            "try:\n    import turtlebot_recon.ros.bags\nexcept ImportError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("1\n") and "genpy" in out.stdout


def test_streams_merge_in_stamp_order_late_and_jumps():
    """in_stamp_order without a bag: a silent stream holds nothing back longer than max_lag_s,
    a record older than one already given is late, a jump back flushes and starts a new run,
    and a stream's records from before its own jump are skipped."""
    def scan(t):
        return LaserRecord(float(t), np.ones(2, np.float32), -1.0, 0.25, 0.12, 3.5)
    recorded = [("scan", scan(t)) for t in range(1, 11)]           # the odometry silent until 10 s
    recorded += [("odom", OdomRecord(2.0, 0, 0, 0, 0, 0)),        # 10 - 5 s of lag: up to 5 s given, late
                 ("odom", OdomRecord(6.0, 0, 0, 0, 0, 0)),        # within the lag: merged
                 ("scan", scan(2.0)),                             # the bag looped (8 s > jump_back_s)
                 ("odom", OdomRecord(9.0, 0, 0, 0, 0, 0))]        # odometry of the first run: skipped
    stats = LogStats("test")
    out = list(in_stamp_order(iter(recorded), ["scan", "odom"], stats, max_lag_s=5.0, jump_back_s=1.0))
    assert [(type(r).__name__[0], r.stamp_s) for r in out] == \
        [("L", t) for t in (1, 2, 3, 4, 5, 6)] + [("O", 6.0)] + [("L", t) for t in (7, 8, 9, 10)] + \
        [("T", 2.0), ("L", 2.0)]
    assert out[-2] == TimeJump(2.0, 10.0)
    assert stats.skipped == {"late": 1, "before the jump": 1} and stats.jumps == [TimeJump(2.0, 10.0)]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same 20 s wander in a 4 x 3 room, without and with wheel slip."""
    from conftest import room, write_world
    d = tmp_path_factory.mktemp("runs")
    world = write_world(d, "room", room(4.0, 3.0), start=[1.0, 1.5, 0.3])
    return {slip: record_run(world, "turtlebot3_burger", 20.0, seed=2, odom_slip=slip, out_dir=d / f"slip{slip}",
                              odom_heading="wheels", bag_writer=write_rosbag)
            for slip in (0.0, 0.02)}


@pytest.mark.parametrize("slip", [0.0, 0.02])
def test_recorded_run_reads_back_from_both_logs(runs, slip):
    run = runs[slip]
    carmen, bag = CarmenReader(run.carmen), BagReader(run.bag)
    c_recs, b_recs = list(carmen), list(bag)
    c_scans = [r for r in c_recs if isinstance(r, LaserRecord)]
    b_scans = [r for r in b_recs if isinstance(r, LaserRecord)]
    assert len(c_scans) == len(b_scans) == run.scans == 100          # 20 s at the LDS-01's 5 Hz
    assert not carmen.stats.skipped and not bag.stats.skipped and not bag.stats.jumps
    for recs in (c_recs, b_recs):
        assert all(a.stamp_s <= b.stamp_s for a, b in zip(recs, recs[1:]))
    assert len([r for r in b_recs if isinstance(r, ImuRecord)]) == 20 * 50
    for c, b in zip(c_scans, b_scans):
        assert c.stamp_s == pytest.approx(b.stamp_s, abs=1e-9)      # the bag keeps nanoseconds
        valid = (b.ranges >= b.range_min) & (b.ranges <= b.range_max)     # bag: raw, 0.0 = dropout
        np.testing.assert_array_equal(c.ranges[valid], b.ranges[valid])
        assert np.isinf(c.ranges[~valid]).all()
    c_odom = [r for r in c_recs if isinstance(r, OdomRecord)]
    b_odom = [r for r in b_recs if isinstance(r, OdomRecord)]
    assert len(c_odom) == len(b_odom) == 2000 // 3      # 30 Hz: every 3rd of 2000 physics steps
    for a, b in zip(c_odom, b_odom):
        assert (a.x, a.y, a.v, a.w) == (b.x, b.y, b.v, b.w) and a.yaw == pytest.approx(b.yaw, abs=1e-12)
    # the scans' odometry against the true pose at the same instants (start frame)
    truth = {round(t, 6): p for t, *p in read_tum(run.ground_truth)}
    err = np.array([np.hypot(s.odom_pose[0] - truth[round(s.stamp_s, 6)][0],
                             s.odom_pose[1] - truth[round(s.stamp_s, 6)][1]) for s in c_scans])
    assert run.distance_m > 2.0 and run.collisions == 0
    if slip == 0.0:
        assert err.max() < 2e-6           # TUM keeps micrometres
    else:
        assert err[-1] > 0.1              # drifted: 0.5 m after 3.4 m at this slip and seed


def test_recorded_runs_share_the_true_path(runs):
    # Same seed and commands: the slip changes the odometry, not the path (the wander steers on scans)
    a, b = read_tum(runs[0.0].ground_truth), read_tum(runs[0.02].ground_truth)
    assert a[0, 0] == pytest.approx(0.1) and np.allclose(a[0, 1:], 0.0, atol=0.01)   # starts at the origin
    assert np.array_equal(a, b)


def test_a_lasers_own_no_return_value_is_recognised_from_the_data(tmp_path):
    """The Intel Lab's SICK writes 81.83 m for no return, below the 81.9 m of the FLASER format:
    the largest reading, repeated far more often than any value near it, is that laser's code."""
    from turtlebot_recon.slam.logs import no_return_value
    rng = np.random.default_rng(3)
    walls = np.round(rng.uniform(0.2, 24.3, (200, 180)), 2).astype(np.float32)   # cm readings
    seen = walls.copy()
    seen[:, 60:70] = 81.83                    # 2000 beams that saw nothing
    assert no_return_value(seen) == pytest.approx(81.83, abs=1e-5)
    assert no_return_value(walls) is None     # no spike: the largest return is a return
    # an LDS-01 that wrote its 3.5 m maximum for no return, among readings spread up to it
    lds = np.round(rng.uniform(0.12, 3.5, (100, 360)), 3).astype(np.float32)
    lds[:, :20] = 3.5
    assert no_return_value(lds) == pytest.approx(3.5)
    assert no_return_value(np.float32([81.83] * 5 + [2.0, 3.0])) is None     # too few to tell
    # read from a log: those readings become +inf and the summary says so
    angles = flaser_geometry(180)
    records = [laser(1.0 + 0.2 * k, seen[k], angle_min=angles[0], inc=angles[1], range_max=81.9, range_min=0.0)
               for k in range(30)]
    path = tmp_path / "intel_like.clf"
    write_carmen(path, records, flaser=True)
    reader = CarmenReader(path)
    back = list(reader)
    assert all(np.isinf(r.ranges[60:70]).all() and np.isfinite(r.ranges[:60]).all() for r in back)
    assert back[0].range_max == pytest.approx(81.83, abs=1e-5)
    assert "no return at 81.83 m on the 180-beam laser (from the data: 300 readings)" in reader.summary()


def test_stamps_that_jitter_keep_the_files_order(tmp_path):
    """The Intel Lab's stamps go back up to 0.9 s between lines whose odometry moves on smoothly:
    sorted by stamp, the robot would jump back and forth; the file's order is kept."""
    rng = np.random.default_rng(5)
    stamps = 10.0 + 0.13 * np.arange(40)
    stamps[5::7] -= rng.uniform(0.3, 0.9, len(stamps[5::7]))        # every 7th line stamped early
    lines = [f"ODOM {0.05 * k} 0.0 0.0 0.2 0.0 0.0 {t} host {t}" for k, t in enumerate(stamps)]
    path = tmp_path / "jitter.clf"
    path.write_text("\n".join(lines) + "\n")
    reader = CarmenReader(path)
    xs = [r.x for r in reader]
    assert xs == sorted(xs) and len(xs) == 40
    assert "the file's order kept" in reader.summary()
    # lines merely logged late (the snippet's late ODOM) are still sorted: test_carmen_snippet
