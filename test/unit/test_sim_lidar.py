"""Lidar by rayTestBatch: ranges to known walls, noise, dropouts and invalid values."""
import math

import numpy as np

from turtlebot_recon.robot import load_robot


def test_ranges_to_known_walls(room_world, make_sim):
    # Room free space x in [0.1, 4.1], y in [0.1, 3.1]; robot at (1.0, 1.5) facing +x.
    sim = make_sim(room_world, "turtlebot3_burger")
    lid = sim.robot.lidar                      # sensor 0.032 m behind base_footprint
    r = sim.true_ranges()
    sx = 1.0 + lid.x_m
    # beam 0 looks along +x: 4.1 - 0.968 = 3.132 m; beam 90 (+y): 3.1 - 1.5 = 1.6 m;
    # beam 180 (-x): 0.968 - 0.1 = 0.868 m; beam 270 (-y): 1.5 - 0.1 = 1.4 m
    assert r[0] == np.float64(r[0]) and abs(r[0] - (4.1 - sx)) < 0.01
    assert abs(r[90] - 1.6) < 0.01 and abs(r[180] - (sx - 0.1)) < 0.01 and abs(r[270] - 1.4) < 0.01
    # a diagonal beam (45 deg) hits the top wall at 1.6 / sin(45 deg) = 2.263 m
    assert abs(r[45] - 1.6 / math.sin(math.radians(45))) < 0.02


def test_noise_matches_spec_and_invalid_returns_are_zero(room_world, make_sim):
    sim = make_sim(room_world, "turtlebot3_burger", seed=3)
    lid = sim.robot.lidar
    truth = sim.true_ranges()
    scans = np.array([sim.scan() for _ in range(200)])
    valid = scans != 0.0                      # LDS-01 reports no return as 0.0
    assert abs((~valid).mean() - lid.dropout_prob) < 0.005
    err = np.where(valid, scans - truth, np.nan)
    sigma = np.maximum(lid.noise_std_m, lid.noise_frac * truth)
    z = err / sigma
    assert abs(np.nanmean(z)) < 0.05 and abs(np.nanstd(z) - 1.0) < 0.05


def test_out_of_range_is_invalid_and_tb2_reports_nan(tmp_path, make_sim):
    from conftest import room, write_world
    # A 12 m corridor: the far end is beyond both lidars' range_max.
    path = write_world(tmp_path, "long", room(12.0, 1.0), start=[1.0, 0.6, 0.0])
    sim = make_sim(path, "turtlebot2", seed=1)
    lid = sim.robot.lidar
    scan = sim.scan()
    centre = lid.beams // 2                   # straight ahead
    assert np.isnan(scan[centre - 2:centre + 3]).all()
    assert np.nanmin(scan) >= lid.range_min_m and np.nanmax(scan) <= lid.range_max_m
    assert load_robot("turtlebot2").lidar.beams == 640 and scan.size == 640
