"""Scan matcher (SLAM front end): known offsets recovered on the simulator's lidar scans,
corridor degeneracy, the covariance's frame and size, the score, bad input.

Scans come from the simulator's LDS-01 (burger: 360 beams, 0.12-3.5 m, noise 1 cm or 1 %,
1 % dropouts) at known poses. A submap is ten scans taken 0.1 m apart along the heading
through a centre pose (yaw alternating +-0.05 rad), in the map frame; the scan to match is taken
at the centre moved by DELTA = (0.15 m, -0.1 m, 0.1 rad) and the guess is the centre itself, so
the matcher has to find all of DELTA. Poses are the lidar's own (the sensor frame), so the
truth is ``sim.sensor_pose``.
"""
import math
import threading

import numpy as np
import pytest

from turtlebot_recon.config import ConfigError, from_dict
from turtlebot_recon.geometry import wrap_angle
from turtlebot_recon.slam.scan_matching import (MatcherSettings, MatchResult, ScanMatcher,
                                                scan_points)

DELTA = np.array([0.15, -0.1, 0.1])
TOL_M, TOL_RAD = 0.02, math.radians(0.5)

HOUSE_ROOM = (3.0, 2.0, 0.5)           # bottom-left room, walls on every side within 3.5 m
HOUSE_HALL = (1.45, 5.45, 0.0)         # the hallway's west end: its end wall fixes x
OFFICE_ROOM = (4.7, 11.0, 0.3)         # west room of the middle block
OFFICE_CORRIDOR = (1.55, 10.95, math.pi / 2)   # west corridor, 1.8 m wide, no end in range
MAZE_CORRIDOR = (5.5, 3.02, 0.0)       # the maze's longest straight corridor: y 2.7-3.3,
                                       # x 3.4-7.5 (its end walls 2 m away)


@pytest.fixture
def sims(make_sim):
    """sims(world) -> a simulator of that world (seeded: each test sees the same scans)."""
    made = {}

    def get(world):
        if world not in made:
            made[world] = make_sim(world, "turtlebot3_burger", seed=7)
        return made[world]

    return get


def lidar(sim, pose, range_max_m=None):
    """(points in the sensor frame, true sensor pose) of one scan with the base at ``pose``."""
    sim.set_pose(*pose)
    lid = sim.robot.lidar
    pts = scan_points(sim.scan(), lid.angle_min_rad, lid.angle_increment_rad, lid.range_min_m,
                      range_max_m or lid.range_max_m)
    return pts, np.array(sim.sensor_pose(lid.x_m, lid.y_m))


def to_map(points, pose):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + pose[:2]


def submap(sim, centre, range_max_m=None):
    """Ten scans 0.1 m apart along the heading through ``centre``, in the map frame."""
    c = np.asarray(centre, float)
    heading = np.array([math.cos(c[2]), math.sin(c[2]), 0.0])
    clouds = []
    for i in range(10):
        pose = c + (-0.45 + 0.1 * i) * heading + [0.0, 0.0, 0.05 * (-1) ** i]
        clouds.append(to_map(*lidar(sim, pose, range_max_m)))
    return np.concatenate(clouds)


def case(sim, centre, range_max_m=None):
    """(scan points, reference, guess, truth): the scan at centre + DELTA, the guess at centre."""
    reference = submap(sim, centre, range_max_m)
    points, truth = lidar(sim, np.asarray(centre) + DELTA, range_max_m)
    _, guess = lidar(sim, centre, range_max_m)
    return points, reference, guess, truth


def errors(result: MatchResult, truth):
    return np.hypot(*(result.pose[:2] - truth[:2])), abs(wrap_angle(result.pose[2] - truth[2]))


def rotation3(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_scan_points_drops_invalid_beams():
    # beams at 0, 90, 180, 270 deg (angle_min 0, increment pi/2), then invalid ones
    ranges = np.array([1.0, 2.0, 0.5, 3.0, np.nan, np.inf, 0.0, 0.05, 4.0], np.float32)
    pts = scan_points(ranges, 0.0, math.pi / 2, 0.12, 3.5)
    # kept: 1 m along +x, 2 m along +y, 0.5 m along -x, 3 m along -y; dropped: NaN, inf,
    # 0.0 (no return), 0.05 < range_min, 4.0 > range_max
    np.testing.assert_allclose(pts, [[1.0, 0.0], [0.0, 2.0], [-0.5, 0.0], [0.0, -3.0]], atol=1e-12)
    assert pts.dtype == np.float64 and pts.shape == (4, 2)
    assert scan_points(np.full(5, np.nan), 0.0, 0.1, 0.1, 3.5).shape == (0, 2)


@pytest.mark.parametrize("world, centre", [("house", HOUSE_ROOM), ("house", HOUSE_HALL),
                                           ("office", OFFICE_ROOM)])
def test_recovers_a_known_offset(sims, world, centre):
    points, reference, guess, truth = case(sims(world), centre)
    result = ScanMatcher().match(points, reference, guess)
    e_xy, e_yaw = errors(result, truth)
    # the guess is DELTA off: 0.18 m and 5.7 deg; the match lands within 2 cm and 0.5 deg
    assert e_xy < TOL_M and e_yaw < TOL_RAD, (e_xy, math.degrees(e_yaw))
    assert not result.degenerate and result.degenerate_direction is None
    assert result.score > 0.9 and result.points_used > 0.8 * len(points)
    cov = result.covariance
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
    # honest, not huge: the translation std is mm-level, like the error
    assert np.sqrt(cov[0, 0]) < 0.02 and np.sqrt(cov[1, 1]) < 0.02


def test_office_corridor_is_degenerate_along_its_axis(sims):
    # The corridor runs along y (map), 1.8 m wide; its ends are beyond 3.5 m: the scan fixes x
    # and yaw, not y.
    points, reference, guess, truth = case(sims("office"), OFFICE_CORRIDOR)
    s = MatcherSettings()
    result = ScanMatcher(s).match(points, reference, guess)
    assert result.degenerate
    d = result.degenerate_direction
    assert abs(np.linalg.norm(d) - 1.0) < 1e-9 and abs(d[1]) > 0.999   # along the corridor
    # Along the corridor the pose stays at the guess (DELTA's -0.1 m in y is not seen)...
    assert abs(d @ (result.pose[:2] - guess[:2])) < 1e-9
    # ... across it and in yaw the offset is recovered
    assert abs(result.pose[0] - truth[0]) < TOL_M and abs(wrap_angle(result.pose[2] - truth[2])) < TOL_RAD
    # Covariance: degenerate_std_m^2 = 1 m^2 along d. It is body-frame; back in the map frame
    # (rotate by the pose's yaw) the variance along d is 1 m^2, across it mm^2.
    cov_map = rotation3(result.pose[2]) @ result.covariance @ rotation3(result.pose[2]).T
    along = d @ cov_map[:2, :2] @ d
    across_dir = np.array([-d[1], d[0]])
    assert abs(along - s.degenerate_std_m ** 2) < 1e-3
    assert across_dir @ cov_map[:2, :2] @ across_dir < 1e-3
    assert np.all(np.linalg.eigvalsh(result.covariance) > 0)


def test_maze_corridor_weak_along_its_axis_and_degenerate_without_its_ends(sims):
    sim = sims("maze")
    # Full range (3.5 m): the LDS-01 sees both end walls 2 m away, so the corridor is only
    # weak along x, not degenerate: the offset is recovered and the covariance's largest
    # translational axis lies along the corridor.
    points, reference, guess, truth = case(sim, MAZE_CORRIDOR)
    result = ScanMatcher().match(points, reference, guess)
    e_xy, e_yaw = errors(result, truth)
    assert e_xy < TOL_M and e_yaw < TOL_RAD and not result.degenerate
    cov_map = rotation3(result.pose[2]) @ result.covariance @ rotation3(result.pose[2]).T
    w, v = np.linalg.eigh(cov_map[:2, :2])
    assert abs(v[0, 1]) > 0.95 and w[1] > 4 * w[0]      # major axis along x, 2x the std across
    # Ranges cut at 1.5 m (a short-range sensor): no end wall in view, the corridor is
    # degenerate along x; the pose keeps the guess's x, recovers y and yaw.
    points, reference, guess, truth = case(sim, MAZE_CORRIDOR, range_max_m=1.5)
    result = ScanMatcher().match(points, reference, guess)
    d = result.degenerate_direction
    assert result.degenerate and abs(d[0]) > 0.999
    assert abs(d @ (result.pose[:2] - guess[:2])) < 1e-9
    assert abs(result.pose[1] - truth[1]) < TOL_M and abs(wrap_angle(result.pose[2] - truth[2])) < TOL_RAD
    cov_map = rotation3(result.pose[2]) @ result.covariance @ rotation3(result.pose[2]).T
    assert abs(cov_map[0, 0] - 1.0) < 1e-3 and cov_map[1, 1] < 1e-3


def test_covariance_is_body_frame_and_shrinks_with_structure(sims):
    points, reference, guess, truth = case(sims("house"), HOUSE_ROOM)
    matcher = ScanMatcher()
    full = matcher.match(points, reference, guess)
    # The same scene turned by 1 rad about the map origin: the map-frame pose turns, the
    # body-frame covariance (GTSAM Pose2's) stays the same.
    turn = 1.0
    R = rotation3(turn)[:2, :2]
    g = np.array([*(R @ guess[:2]), guess[2] + turn])
    turned = matcher.match(points, reference @ R.T, g)
    # (up to the grid's cells, which fall differently on the turned walls: mm in the pose; in the
    # covariance ~20 %, the lines' normals fitted over a disc two cells wide: 3 % with 0.15 m)
    np.testing.assert_allclose(turned.pose[:2], R @ full.pose[:2], atol=3e-3)
    size = np.linalg.norm(full.covariance)
    body_change = np.linalg.norm(turned.covariance - full.covariance)
    map_change = np.linalg.norm(turned.covariance - rotation3(turn) @ full.covariance @ rotation3(turn).T)
    assert body_change < 0.3 * size and map_change > 3 * body_change
    # Only the beams within 40 deg of the sensor's heading (mostly one wall): less structure,
    # a larger covariance in translation and in yaw.
    front = points[np.abs(np.arctan2(points[:, 1], points[:, 0])) < math.radians(40)]
    narrow = matcher.match(front, reference, guess)
    assert narrow is not None
    assert np.trace(narrow.covariance[:2, :2]) > 2 * np.trace(full.covariance[:2, :2])
    assert narrow.covariance[2, 2] > full.covariance[2, 2]


def test_wrong_reference_scores_low_or_is_refused(sims):
    sim = sims("house")
    points, reference, guess, truth = case(sim, HOUSE_ROOM)
    matcher = ScanMatcher()
    assert matcher.match(points, reference, guess).score > 0.9
    # The same scan against submaps of other rooms, guessed at their centres (wrong loop
    # closure candidates): either the best alignment explains under half of the scan, or ICP,
    # chasing wrong pairs, slides away from the coarse pose and the match is refused.
    others = [(4.1, 9.3, 0.5), (12.0, 9.7, -2.5), (14.0, 7.0, -0.5), (14.0, 7.0, 2.5),
              (2.4, 7.2, 0.5), (9.6, 7.8, -2.5)]
    scored = 0
    for other in others:
        wrong = matcher.match(points, submap(sim, other), lidar(sim, other)[1])
        if wrong is None:
            assert "ICP slid" in matcher.last_failure or "too few" in matcher.last_failure
        else:
            assert wrong.score < 0.5, (other, wrong.score)
            scored += 1
    assert scored >= 3   # (4 of 6 with seed 7)


def test_too_few_points_is_none_with_a_reason(sims):
    points, reference, guess, _ = case(sims("house"), HOUSE_ROOM)
    matcher = ScanMatcher(MatcherSettings(min_points=30))
    assert matcher.match(points[:29], reference, guess) is None
    assert "too few scan points" in matcher.last_failure and "29" in matcher.last_failure
    assert matcher.match(points, reference[:20], guess) is None
    assert "too few reference points" in matcher.last_failure
    # a reference far from the guess: nothing near it to match
    assert matcher.match(points, reference + 50.0, guess) is None
    assert "too few reference points near the guess" in matcher.last_failure
    assert matcher.match(points, reference, guess) is not None and matcher.last_failure is None
    # every point at one spot: no line to pair with
    assert matcher.match(points, np.zeros((100, 2)), (0.0, 0.0, 0.0)) is None
    assert "pairs" in matcher.last_failure


def test_bad_input_raises_value_error_naming_it():
    matcher = ScanMatcher()
    pts, ref = np.ones((40, 2)), np.ones((40, 2))
    with pytest.raises(ValueError, match="guess must be 3 finite numbers"):
        matcher.match(pts, ref, (0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match="guess must be 3 finite"):
        matcher.match(pts, ref, (0.0, 0.0))
    bad = pts.copy()
    bad[7, 1] = math.nan
    with pytest.raises(ValueError, match="points must be finite, row 7"):
        matcher.match(bad, ref, (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="reference must be finite"):
        matcher.match(pts, np.vstack([ref, [math.inf, 0.0]]), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"points must be an \(n, 2\) array.*\(40, 3\)"):
        matcher.match(np.ones((40, 3)), ref, (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"views must have one row per reference point \(40\), got 39"):
        matcher.match(pts, ref, (0.0, 0.0, 0.0), np.zeros((39, 2)))
    with pytest.raises(ValueError, match="views must be finite"):
        matcher.match(pts, ref, (0.0, 0.0, 0.0), np.full((40, 2), math.nan))


def test_settings_are_validated():
    with pytest.raises(ConfigError, match="grid_resolution_m"):
        MatcherSettings(grid_resolution_m=0.0)
    with pytest.raises(ConfigError, match="coarse_resolution_m"):
        MatcherSettings(coarse_resolution_m=0.01)
    with pytest.raises(ConfigError, match="degeneracy_ratio"):
        from_dict(MatcherSettings, {"degeneracy_ratio": 1.5}, "slam.yaml/matcher")
    assert from_dict(MatcherSettings, {"search_xy_m": 1.0}, "x").search_xy_m == 1.0


def test_calls_from_two_threads_give_the_same_answer(sims):
    points, reference, guess, _ = case(sims("office"), OFFICE_ROOM)
    matcher = ScanMatcher()
    expected = matcher.match(points, reference, guess).pose
    results = []
    threads = [threading.Thread(target=lambda: results.extend(
        matcher.match(points, reference, guess).pose for _ in range(20))) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(results) == 40 and all(np.array_equal(p, expected) for p in results)



def segment(a, b, step_m=0.02):
    """Points every ``step_m`` from a to b (m)."""
    n = int(round(math.dist(a, b) / step_m)) + 1
    return np.linspace(a, b, n)


def test_a_thin_wall_seen_from_both_sides_pulls_a_scan_only_without_viewpoints():
    """A partition 5 cm thick (one cell of a grid map: a door frame, the wall between two
    rooms) is in the submap from both sides: its south face (y = 0) seen from the south, its
    north face (y = 0.05) from the north; an end wall at x = 2 fixes x. A scan from the south
    sees the south face. Without viewpoints one line runs down the partition's middle and the
    scan is pulled 2.5 cm north, towards where the robot was before (this shrank a house's
    map by 0.5 %); with them the scan pairs with the face its rays meet."""
    rng = np.random.default_rng(3)
    south_view, north_view = np.array([0.0, -0.8]), np.array([0.0, 0.9])
    south = np.vstack([segment((-2.0, 0.0), (1.98, 0.0)), segment((2.0, -1.5), (2.0, -0.02))])
    north = np.vstack([segment((-2.0, 0.05), (1.98, 0.05)), segment((2.0, 0.07), (2.0, 1.5))])
    reference = np.vstack([south, north]) + rng.normal(0.0, 0.005, (len(south) + len(north), 2))
    views = np.vstack([np.tile(south_view, (len(south), 1)), np.tile(north_view, (len(north), 1))])
    truth = np.array([0.1, -0.7, 0.05])
    seen = np.vstack([segment((-1.6, 0.0), (1.98, 0.0)), segment((2.0, -1.4), (2.0, -0.02))])
    seen = seen + rng.normal(0.0, 0.005, seen.shape)
    c, s = math.cos(truth[2]), math.sin(truth[2])
    scan = (seen - truth[:2]) @ np.array([[c, -s], [s, c]])      # the map points in the scan's frame
    guess = truth + np.array([0.05, -0.04, 0.02])
    matcher = ScanMatcher()
    with_views = matcher.match(scan, reference, guess, views)
    without = matcher.match(scan, reference, guess)
    assert with_views is not None and without is not None
    assert np.hypot(*(with_views.pose[:2] - truth[:2])) < 0.005, with_views.pose
    assert abs(wrap_angle(with_views.pose[2] - truth[2])) < 0.002
    assert without.pose[1] - truth[1] > 0.015, without.pose     # pulled into the wall's middle


def corridor_with_doors(tmp_path):
    """A corridor 1.2 m wide and 15.6 m long between walls 0.1 m thick, with a 0.8 m door into
    a room every 3.5 m on either side (the door jambs are what fix a scan along it)."""
    from conftest import write_world
    res = 0.05
    free = np.zeros((int(6.0 / res), int(16.0 / res)), bool)

    def box(x0, y0, x1, y1):
        free[int(round(y0 / res)):int(round(y1 / res)), int(round(x0 / res)):int(round(x1 / res))] = True
    box(0.2, 2.4, 15.8, 3.6)
    for k in range(4):
        x0 = 1.0 + 3.5 * k
        box(x0, 3.7, x0 + 3.0, 5.6)               # a room north ...
        box(x0 + 1.0, 3.6, x0 + 1.8, 3.7)         # ... and its door
        box(x0 + 0.5, 0.4, x0 + 2.5, 2.3)         # a room south ...
        box(x0 + 1.5, 2.3, x0 + 2.3, 2.4)         # ... and its door
    return write_world(tmp_path, "corridor", free, start=[1.0, 3.0, 0.0])


@pytest.mark.parametrize("radius_m, biased", [(MatcherSettings().normal_radius_m, False), (0.15, True)])
def test_door_jambs_do_not_push_a_corridors_matches_forward(make_sim, tmp_path, radius_m, biased):
    """Keyframes every 0.25 m down the corridor (noise-free scans at known poses), each matched
    to the 12 before it, as SLAM's submap: the mean error along the corridor stays under 1 mm.
    A line fitted over 0.15 m took in a door jamb's end face with the corridor wall's: +2.4 mm
    forward per keyframe, a map stretched by 1 % (the recorded house drive: +0.6 %)."""
    sim = make_sim(corridor_with_doors(tmp_path), seed=1)
    lid = sim.robot.lidar
    matcher = ScanMatcher(MatcherSettings(normal_radius_m=radius_m))
    keyframes, errors = [], []
    for x in np.arange(1.0, 14.0, 0.25):
        pose = np.array([x, 3.0 + 0.05 * math.sin(x), 0.02 * math.cos(2 * x)])
        sim.set_pose(*pose)
        pts = scan_points(sim.true_ranges(), lid.angle_min_rad, lid.angle_increment_rad, lid.range_min_m,
                          lid.range_max_m) + np.array([lid.x_m, lid.y_m])
        if keyframes:
            ref = np.vstack([to_map(p, q) for q, p in keyframes[-12:]])
            views = np.vstack([np.tile(q[:2], (len(p), 1)) for q, p in keyframes[-12:]])
            result = matcher.match(pts, ref, pose, views)
            assert result is not None, matcher.last_failure
            errors.append(result.pose - pose)
        keyframes.append((pose, pts))
    along = float(np.mean(np.asarray(errors)[:, 0]))
    assert (along > 0.0018) if biased else (abs(along) < 0.001), along
