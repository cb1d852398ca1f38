"""The tag tracker: map transform, covariance-weighted fusion, gating, confirmation, files."""
import dataclasses
import math

import cv2
import numpy as np
import pytest
import yaml

from turtlebot_recon.geometry import wrap_angle
from turtlebot_recon.perception.detection import TagDetection
from turtlebot_recon.perception.tracker import (CSV_HEADER, TagTracker, TrackerSettings,
                                                load_tags_yaml, sighting_in_map, to_csv,
                                                to_standalone_tags_yaml)

# The optical frame of a camera on a robot at yaw 0: x_opt = -y_map, y_opt = -z_map,
# z_opt = +x_map (the columns of R_map_optical).
R_MAP_OPTICAL_YAW0 = np.array([[0.0, 0.0, 1.0],
                               [-1.0, 0.0, 0.0],
                               [0.0, -1.0, 0.0]])
WALL = (3.0, 0.0, 0.3)          # a marker on a wall at x = 3 m, facing -x (yaw pi)


def rot_z(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def camera(x, y, yaw, z=0.3):
    """T_map_optical of a level camera at (x, y, z) looking along map heading ``yaw``."""
    T = np.eye(4)
    T[:3, :3] = rot_z(yaw) @ R_MAP_OPTICAL_YAW0
    T[:3, 3] = (x, y, z)
    return T


def upright(yaw):
    """R_map_marker of an upright marker whose normal (z) has heading ``yaw``; y is up."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[-s, 0.0, c], [c, 0.0, s], [0.0, 1.0, 0.0]])


def cov6(pos_std, rot_std):
    return np.diag([pos_std ** 2] * 3 + [rot_std ** 2] * 3)


def seen(T, xyz, yaw=math.pi, R_map_marker=None, cov=None, family="tag36h11", tag_id=3,
         size=0.16, ambiguous=False):
    """The detection a camera at T makes of a marker it measures at map pose (xyz, yaw)."""
    R_mo, t = T[:3, :3], T[:3, 3]
    R_mm = upright(yaw) if R_map_marker is None else R_map_marker
    return TagDetection(family=family, id=tag_id, size_m=size, corners_px=np.zeros((4, 2)),
                        position_m=R_mo.T @ (np.asarray(xyz, float) - t), rotation=R_mo.T @ R_mm,
                        covariance=cov6(0.01, 0.05) if cov is None else cov,
                        decision_margin=50.0, reprojection_px=0.3,
                        ambiguity=0.9 if ambiguous else 0.1, ambiguous=ambiguous)


def only_track(tracker):
    (track,) = tracker.tags(confirmed_only=False)
    return track


# ----------------------------------------------------------------------------- settings

@pytest.mark.parametrize("key, value", [("confirm_sightings", 0), ("confirm_sightings", 1.5),
                                        ("gate_chi2", -1.0), ("min_position_std_m", 0.0),
                                        ("max_distance_m", float("nan")),
                                        ("restart_after_rejections", 0),
                                        ("max_tilt_rad", math.pi / 2)])
def test_bad_settings_name_the_key(key, value):
    with pytest.raises(ValueError, match=key):
        TrackerSettings(**{key: value})


def test_bad_camera_pose_is_refused():
    T = camera(0.0, 0.0, 0.0)
    T[:3, :3] *= 2.0
    with pytest.raises(ValueError, match="T_map_optical"):
        TagTracker(TrackerSettings()).update(seen(camera(0, 0, 0), WALL), T, 0.0)


# -------------------------------------------------------------------------- map frame

def test_marker_straight_ahead_lands_one_metre_in_front_of_the_camera():
    # Built by hand: the marker 1 m along the optical axis, facing the camera: its z (normal)
    # is -z_opt, its y (up) is -y_opt, its x = y cross z = +x_opt.
    det = TagDetection(family="tag36h11", id=3, size_m=0.16, corners_px=np.zeros((4, 2)),
                       position_m=np.array([0.0, 0.0, 1.0]),
                       rotation=np.diag([1.0, -1.0, -1.0]), covariance=cov6(0.01, 0.05),
                       decision_margin=50.0, reprojection_px=0.3, ambiguity=0.1,
                       ambiguous=False)
    tracker = TagTracker(TrackerSettings())
    tracker.update(det, camera(1.0, 2.0, 0.0, z=0.2), 0.0)
    x, y, z, yaw = only_track(tracker).mean
    # Camera at (1, 2, 0.2) looking along +x: the marker at (2, 2, 0.2), its normal along -x.
    assert (x, y, z) == pytest.approx((2.0, 2.0, 0.2), abs=1e-12)
    assert abs(wrap_angle(yaw - math.pi)) < 1e-12
    # The same camera turned to yaw 90 deg: ahead is +y, the normal points along -y.
    z_map, _, _ = sighting_in_map(det, camera(1.0, 2.0, math.pi / 2, z=0.2))
    assert z_map == pytest.approx([1.0, 3.0, 0.2, -math.pi / 2], abs=1e-12)
    # Right (x_opt) and down (y_opt) of the axis: at yaw 0, right is -y and down is -z.
    off = TagDetection(**{**det.__dict__, "position_m": np.array([0.5, 0.1, 1.0])})
    z_map, _, _ = sighting_in_map(off, camera(1.0, 2.0, 0.0, z=0.2))
    assert z_map[:3] == pytest.approx([2.0, 1.5, 0.1], abs=1e-12)


def test_covariance_is_rotated_into_the_map():
    # Optical variances: x 1e-4, y 4e-4, z (depth) 9e-4; rotations rx 1e-3, ry 4e-3, rz 9e-3.
    det = seen(camera(1.0, 0.0, 0.0), WALL,
               cov=np.diag([1e-4, 4e-4, 9e-4, 1e-3, 4e-3, 9e-3]))
    _, R, tilt = sighting_in_map(det, camera(1.0, 0.0, 0.0))
    # Looking along +x: depth is map x, optical x is map -y, optical y is map -z; the upright
    # marker's yaw turns about map z = -y_opt, so only ry reaches yaw.
    assert np.diag(R) == pytest.approx([9e-4, 1e-4, 4e-4, 4e-3], rel=1e-12)
    assert tilt == pytest.approx(0.0, abs=1e-12)


def test_yaw_covariance_matches_a_numerical_jacobian_for_a_tilted_marker():
    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6)) * 0.05
    C = A @ A.T + 1e-4 * np.eye(6)
    T = camera(0.5, -0.4, 0.4)
    tilted = upright(2.8) @ cv2.Rodrigues(np.array([-0.5, 0.0, 0.0]))[0]  # normal 0.5 rad up
    det = seen(T, (2.6, 0.3, 0.5), R_map_marker=tilted, cov=C)
    z0, R, tilt = sighting_in_map(det, T)
    assert tilt == pytest.approx(0.5, abs=1e-9)
    # Perturb the detection along each of its six covariance axes (position in the optical
    # frame; small rotations about the optical axes, applied on the left).
    eps, J = 1e-7, np.zeros((4, 6))
    for k in range(6):
        d = np.zeros(6)
        d[k] = eps
        moved = TagDetection(**{**det.__dict__, "position_m": det.position_m + d[:3],
                                "rotation": cv2.Rodrigues(d[3:])[0] @ det.rotation})
        z1, _, _ = sighting_in_map(moved, T)
        J[:, k] = (z1 - z0) / eps
    assert R == pytest.approx(J @ C @ J.T, rel=1e-5, abs=1e-12)


# ---------------------------------------------------------------------------- fusion

def test_precise_sighting_outweighs_a_vague_one():
    tracker = TagTracker(TrackerSettings())
    near = seen(camera(2.0, 0.0, 0.0), (WALL[0] + 0.01, 0.0, 0.3), cov=cov6(0.01, 0.05))
    far = seen(camera(0.2, 0.0, 0.0), (WALL[0] - 0.2, 0.0, 0.3), cov=cov6(0.2, 0.05))
    assert tracker.update(near, camera(2.0, 0.0, 0.0), 0.0) == "tentative"
    assert tracker.update(far, camera(0.2, 0.0, 0.0), 1.0) == "confirmed"
    x = only_track(tracker).mean[0] - WALL[0]
    # Inverse-variance weights 1/0.01² = 10000 and 1/0.2² = 25:
    # x = (10000 * 0.01 + 25 * -0.2) / 10025 = 0.009476 m; the plain mean is -0.095 m.
    assert x == pytest.approx(0.009476, abs=1e-5)
    assert abs(x) < abs((0.01 - 0.2) / 2) / 9


def survey(rng, truth=np.array([2.0, 1.0, 0.25]), truth_yaw=-math.pi / 2, n=15):
    """n noisy sightings of a marker (on a wall facing -y) from random poses within 0.8..3 m
    and 0.8 rad of its normal, noise drawn from each detection's covariance. Returns the
    track and the map positions of the single sightings."""
    tracker = TagTracker(TrackerSettings())
    positions = []
    for i in range(n):
        dist = rng.uniform(0.8, 3.0)
        bearing = truth_yaw + rng.uniform(-0.8, 0.8)             # camera off the normal
        T = camera(*(truth[:2] + dist * np.array([math.cos(bearing), math.sin(bearing)])),
                   bearing + math.pi)
        # Depth error grows with distance², lateral and angular errors with distance.
        std = np.array([0.003 * dist, 0.003 * dist, 0.01 * dist ** 2] + [0.02 * dist] * 3)
        noise = rng.normal(size=6) * std
        det = seen(T, truth, truth_yaw, cov=np.diag(std ** 2))
        det = TagDetection(**{**det.__dict__, "position_m": det.position_m + noise[:3],
                              "rotation": cv2.Rodrigues(noise[3:])[0] @ det.rotation})
        assert tracker.update(det, T, float(i)) in ("tentative", "confirmed", "fused")
        positions.append(sighting_in_map(det, T)[0][:3])
    return only_track(tracker), np.array(positions)


def test_noisy_sightings_from_many_poses_converge():
    rng = np.random.default_rng(4)
    truth, truth_yaw = np.array([2.0, 1.0, 0.25]), -math.pi / 2
    fused, plain = [], []
    for _ in range(30):
        track, positions = survey(rng, truth, truth_yaw)
        assert track.state == "confirmed" and track.sightings == 15
        error = np.linalg.norm(track.position_m - truth)
        assert error < np.linalg.norm(positions - truth, axis=1).max() / 5   # worst single
        assert abs(wrap_angle(track.yaw_rad - truth_yaw)) < 0.03
        # The covariance is honest: the truth lies inside the estimate's 99.9 % ellipsoid.
        P = np.array(track.covariance)[:3, :3]
        assert (track.position_m - truth) @ np.linalg.solve(P, track.position_m - truth) < 16.27
        fused.append(error)
        plain.append(np.linalg.norm(positions.mean(axis=0) - truth))
    # Weighting by covariance beats the unweighted mean of the same sightings (measured:
    # RMS 4.2 mm against 12.3 mm over 100 such surveys).
    assert np.sqrt(np.mean(np.square(fused))) < 0.5 * np.sqrt(np.mean(np.square(plain)))


def test_yaw_is_fused_across_the_wrap():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    tracker.update(seen(T, WALL, math.radians(179.0)), T, 0.0)
    assert tracker.update(seen(T, WALL, math.radians(-179.0)), T, 1.0) == "confirmed"
    # Equal weights: halfway along the short arc, 180 deg (not the 0 of a plain average).
    assert abs(wrap_angle(only_track(tracker).yaw_rad - math.pi)) < 1e-9


def test_one_perfect_looking_sighting_does_not_freeze_the_estimate():
    tracker = TagTracker(TrackerSettings(min_position_std_m=0.01))
    T = camera(1.0, 0.0, 0.0)
    tracker.update(seen(T, WALL, cov=cov6(1e-7, 1e-7)), T, 0.0)
    assert tracker.update(seen(T, (WALL[0], 0.02, WALL[2]), cov=cov6(0.01, 0.05)), T, 1.0) \
        == "confirmed"
    # Both floored to std 0.01 m: the second pulls the estimate halfway, to y = 0.01 m.
    assert only_track(tracker).mean[1] == pytest.approx(0.01, abs=1e-6)


# ------------------------------------------------------- confirmation, outliers, filters

def test_confirmed_exactly_on_the_second_consistent_sighting():
    tracker = TagTracker(TrackerSettings(confirm_sightings=2))
    T = camera(1.0, 0.0, 0.0)
    assert tracker.update(seen(T, WALL), T, 0.0) == "tentative"
    assert tracker.tags() == [] and only_track(tracker).state == "tentative"
    assert tracker.update(seen(T, (3.5, 0.0, 0.3)), T, 1.0) == "rejected_outlier"
    assert tracker.tags() == []                       # an inconsistent sighting confirms nothing
    assert tracker.update(seen(T, (3.005, 0.0, 0.3)), T, 2.0) == "confirmed"
    assert [t.id for t in tracker.tags()] == [3]
    assert tracker.update(seen(T, WALL), T, 3.0) == "fused"
    assert tracker.stats["confirmed"] == 1 and tracker.stats["fused"] == 2


def test_gross_outlier_is_rejected_and_leaves_a_confirmed_estimate_alone():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    tracker.update(seen(T, WALL), T, 0.0)
    tracker.update(seen(T, WALL), T, 1.0)
    before = only_track(tracker)
    for i in range(5):                                # confirmed tags never restart
        assert tracker.update(seen(T, (3.0, 1.0, 0.3)), T, 2.0 + i) == "rejected_outlier"
    after = only_track(tracker)
    assert after.mean == before.mean and after.covariance == before.covariance
    assert after.rejected == 5 and tracker.stats["rejected_outlier"] == 5
    assert after.last_seen_s == 1.0


def test_a_contradicted_tentative_tag_restarts_from_the_new_sightings():
    tracker = TagTracker(TrackerSettings(restart_after_rejections=3))
    T = camera(1.0, 0.0, 0.0)
    assert tracker.update(seen(T, (3.0, 0.5, 0.3)), T, 0.0) == "tentative"   # a wrong start
    assert tracker.update(seen(T, WALL), T, 1.0) == "rejected_outlier"
    assert tracker.update(seen(T, WALL), T, 2.0) == "rejected_outlier"
    # The third in a row: restart from the three, which agree -> confirmed at once.
    assert tracker.update(seen(T, WALL), T, 3.0) == "confirmed"
    track = only_track(tracker)
    assert track.mean[:3] == pytest.approx(WALL, abs=1e-9)
    assert (track.sightings, track.rejected, track.first_seen_s) == (3, 3, 0.0)
    assert tracker.stats["restarted"] == 1


def test_ambiguous_detections_never_enter_the_map():
    tracker = TagTracker(TrackerSettings(confirm_sightings=1))
    T = camera(1.0, 0.0, 0.0)
    for i in range(3):
        assert tracker.update(seen(T, WALL, ambiguous=True), T, float(i)) == "ignored_ambiguous"
    assert tracker.tags(confirmed_only=False) == []
    assert tracker.stats["ignored_ambiguous"] == 3 and tracker.stats["sightings"] == 3


def test_far_tilted_and_resized_sightings_are_ignored():
    tracker = TagTracker(TrackerSettings(max_distance_m=3.0, max_tilt_rad=0.7))
    T = camera(-0.5, 0.0, 0.0)                                       # 3.5 m from the wall
    assert tracker.update(seen(T, WALL), T, 0.0) == "ignored_far"
    T = camera(1.0, 0.0, 0.0)
    facing_up = upright(math.pi) @ cv2.Rodrigues(np.array([-1.0, 0.0, 0.0]))[0]  # 1 rad up
    assert tracker.update(seen(T, WALL, R_map_marker=facing_up), T, 1.0) == "ignored_tilted"
    assert tracker.tags(confirmed_only=False) == []
    assert tracker.update(seen(T, WALL), T, 2.0) == "tentative"
    assert tracker.update(seen(T, WALL, size=0.10), T, 3.0) == "ignored_size"
    assert only_track(tracker).sightings == 1


def test_aruco_dictionaries_of_one_bit_size_share_ids():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    assert tracker.update(seen(T, WALL, family="aruco_6x6_100", tag_id=7, size=0.1), T, 0.0) \
        == "tentative"
    assert tracker.update(seen(T, WALL, family="aruco_6x6_250", tag_id=7, size=0.1), T, 1.0) \
        == "confirmed"
    assert tracker.update(seen(T, WALL, family="aruco_5x5_100", tag_id=7, size=0.1), T, 2.0) \
        == "tentative"                                              # another marker set
    assert [(t.family, t.id, t.state) for t in tracker.tags(confirmed_only=False)] == [
        ("aruco_5x5_100", 7, "tentative"), ("aruco_6x6_100", 7, "confirmed")]


# ----------------------------------------------------------------------------- files

def three_tags():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    for family, tag_id, n in (("tag36h11", 3, 2), ("aruco_6x6_250", 3, 3),
                              ("aruco_6x6_100", 12, 1)):
        for i in range(n):
            xyz = (WALL[0] + 0.003 * i, 0.1 * tag_id, WALL[2])
            tracker.update(seen(T, xyz, 3.1, family=family, tag_id=tag_id), T, 10.0 + i)
    return tracker.tags(confirmed_only=False)


def test_yaml_is_apriltag_ros_standalone_tags_and_round_trips():
    tracks = three_tags()
    text = to_standalone_tags_yaml(tracks)
    entries = yaml.safe_load(text)["standalone_tags"]
    # apriltag_ros asserts an int id and a double size; the name is its TF frame.
    assert [(type(e["id"]), type(e["size"])) for e in entries] == [(int, float)] * 3
    assert [e["name"] for e in entries] == ["tag_12", "aruco_6x6_tag_3", "tag36h11_tag_3"]
    assert load_tags_yaml(text) == tracks
    assert [(t.id, t.state) for t in tracks] == [(12, "tentative"), (3, "confirmed"),
                                               (3, "confirmed")]


def test_yaml_keeps_one_id_in_two_marker_sets_with_different_sizes():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    tracker.update(seen(T, WALL, family="tag36h11", tag_id=3, size=0.16), T, 0.0)
    tracker.update(seen(T, WALL, family="aruco_4x4_50", tag_id=3, size=0.10), T, 0.0)
    tracks = tracker.tags(confirmed_only=False)
    assert [(t.family, t.size_m) for t in load_tags_yaml(to_standalone_tags_yaml(tracks))] == \
        [("aruco_4x4_50", 0.10), ("tag36h11", 0.16)]


def _entries():
    return yaml.safe_load(to_standalone_tags_yaml(three_tags()))["standalone_tags"]


# The entries, sorted by (family, id): [0] aruco_6x6_100 12, [1] aruco_6x6_250 3, [2] tag36h11 3.
@pytest.mark.parametrize("change, message", [
    (lambda e: e[0].pop("x"), r"standalone_tags\[0\] \(id 12\): missing key 'x'"),
    (lambda e: e[1].update(y="north"), r"standalone_tags\[1\] \(id 3\): key 'y'"),
    (lambda e: e[0].update(id=-2), r"standalone_tags\[0\]: key 'id'"),
    (lambda e: e[2].update(size=0.0), r"\[2\] \(id 3\): key 'size'"),
    (lambda e: e[2].update(family="tag99h1"), r"\[2\] \(id 3\): key 'family'"),
    (lambda e: e[0].update(yaw=0.0), r"\[0\] \(id 12\): keys 'qw qx qy qz'"),
    (lambda e: e[0].update(covariance=[[1.0, 0.0], [0.0, 1.0]]),
     r"\[0\] \(id 12\): key 'covariance'"),
    (lambda e: e[0]["covariance"][0].__setitem__(1, 5.0), r"\[0\] \(id 12\): key 'covariance'"),
    (lambda e: e[1].update(state="lost"), r"\[1\] \(id 3\): key 'state'"),
    (lambda e: e[1].update(sightings=0), r"\[1\] \(id 3\): key 'sightings'"),
    (lambda e: e[0].update(id=3, family="aruco_6x6_50"),
     r"\[1\]: id 3 of aruco_6x6 is listed twice \(also standalone_tags\[0\]\)"),
])
def test_bad_yaml_entries_are_refused_naming_entry_and_key(change, message):
    entries = _entries()
    change(entries)
    with pytest.raises(ValueError, match=message):
        load_tags_yaml(yaml.safe_dump({"standalone_tags": entries}))


@pytest.mark.parametrize("text, message", [
    ("standalone_tags: [{id: 3, size: 0.16, name: tag_3}]", "missing key 'family'"),
    ("standalone_tags: {id: 3}", "'standalone_tags' list"),
    ("tags: [", "not valid YAML"),
])
def test_bad_yaml_files_are_refused(text, message):
    with pytest.raises(ValueError, match=message):
        load_tags_yaml(text)


def test_csv_has_one_row_per_tag_with_the_header():
    tracks = three_tags()
    lines = to_csv(tracks).splitlines()
    assert lines[0] == CSV_HEADER
    assert len(lines) == 4
    row = dict(zip(CSV_HEADER.split(","), lines[3].split(",")))
    t = tracks[2]
    assert (int(row["id"]), row["family"], int(row["sightings"])) == (t.id, t.family, t.sightings)
    assert [float(row[k]) for k in ("x", "y", "z", "yaw")] == list(t.mean)
    assert float(row["cov_xy"]) == t.covariance[0][1]
    assert float(row["cov_yawyaw"]) == t.covariance[3][3]


def test_unconfirmed_lists_tentative_tags_and_glimpses_kept_out_of_the_map():
    tracker = TagTracker(TrackerSettings())
    T = camera(1.0, 0.0, 0.0)
    tracker.update(seen(T, WALL, family="tag36h11", tag_id=3, size=0.16), T, 0.0)
    amb = dataclasses.replace(seen(T, WALL, family="tag36h11", tag_id=4, size=0.16), ambiguous=True)
    assert tracker.update(amb, T, 0.1) == "ignored_ambiguous"
    u = tracker.unconfirmed()
    assert [(g.family, g.id) for g in u] == [("tag36h11", 3), ("tag36h11", 4)]
    assert tracker.tags() == []                      # neither is in the map
    glimpse = u[1]
    cam = T[:3, 3]
    assert math.isclose(glimpse.yaw, math.atan2(cam[1] - glimpse.y, cam[0] - glimpse.x), abs_tol=1e-9)
    tracker.update(seen(T, WALL, family="tag36h11", tag_id=3, size=0.16), T, 0.2)   # confirmed
    assert [(g.family, g.id) for g in tracker.unconfirmed()] == [("tag36h11", 4)]
