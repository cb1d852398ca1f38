"""Trajectory metrics: TUM files, ATE with and without alignment, the relations metric, the CLI."""
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from turtlebot_recon.evaluation.trajectory_metrics import (align_se2, associate, ate, interpolate, make_relations,
                                                           read_relations, read_tum, relation_errors, relations_error,
                                                           write_relations, write_tum, yaw_from_quaternion)
from turtlebot_recon.geometry import compose, wrap_angle

CLI = Path(__file__).resolve().parents[2] / "tools" / "slam_eval.py"


def loop(n=201, duration_s=20.0):
    """(n, 4) a robot driving a circle of radius 2 m once, facing along it, at 10 Hz."""
    t = np.linspace(0.0, duration_s, n)
    a = 2 * math.pi * t / duration_s
    return np.column_stack([t, 2 * np.sin(a), 2 - 2 * np.cos(a), wrap_angle(a)])


def moved(traj, motion):
    """The trajectory seen from another frame: every pose premultiplied by ``motion``."""
    return np.column_stack([traj[:, 0], compose(motion, traj[:, 1:4])])


def test_tum_round_trip_and_quaternion_yaw(tmp_path):
    gt = loop()
    write_tum(tmp_path / "a.tum", gt)
    back = read_tum(tmp_path / "a.tum")
    np.testing.assert_allclose(back[:, :3], gt[:, :3], atol=1e-6)
    np.testing.assert_allclose(wrap_angle(back[:, 3] - gt[:, 3]), 0.0, atol=1e-8)
    # a rotation of 30 deg about z: q = (0, 0, sin 15 deg, cos 15 deg)
    assert yaw_from_quaternion(0.0, 0.0, math.sin(math.radians(15)), math.cos(math.radians(15))) == \
        pytest.approx(math.radians(30))
    (tmp_path / "bad.tum").write_text("# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n")
    with pytest.raises(ValueError, match="bad.tum:3: a TUM line has 8 numbers, this one 7"):
        read_tum(tmp_path / "bad.tum")


def test_associate_nearest_within_tolerance():
    i, j = associate([0.0, 0.09, 0.5, 1.04], [0.0, 0.1, 0.2, 1.0], max_dt_s=0.02)
    assert i.tolist() == [0, 1] and j.tolist() == [0, 1]       # 0.5 has nothing near, 1.04 is 0.04 off


def test_ate_of_itself_is_zero_and_of_a_shifted_copy_is_the_shift():
    gt = loop()
    assert ate(gt, gt).rmse_m == 0.0
    shifted = gt.copy()
    shifted[:, 1:3] += (0.3, -0.4)
    r = ate(shifted, gt)
    assert r.rmse_m == pytest.approx(0.5) and r.max_m == pytest.approx(0.5) and r.matched == r.total == 201


def test_align_removes_a_rotation_and_shift():
    gt = loop()
    est = moved(gt, (1.5, -0.7, math.radians(25)))
    assert ate(est, gt).rmse_m > 1.0
    r = ate(est, gt, align=True)
    assert r.rmse_m < 1e-9
    # the alignment found is the inverse motion: 25 deg back
    assert r.alignment[2] == pytest.approx(math.radians(-25))
    assert align_se2(gt[:, 1:3], est[:, 1:3]) == pytest.approx([1.5, -0.7, math.radians(25)])


def test_ate_refuses_trajectories_that_do_not_overlap_in_time():
    gt = loop()
    late = gt.copy()
    late[:, 0] += 100.0
    with pytest.raises(ValueError, match="no estimated pose within 0.02 s"):
        ate(late, gt)


def test_interpolation_between_poses_and_outside():
    traj = np.array([[0.0, 0.0, 0.0, 3.0], [1.0, 1.0, 2.0, -3.0]])    # yaw crosses +-pi
    p = interpolate(traj, np.array([0.5, 1.01, 2.0]), max_dt_s=0.02)
    # half-way: (0.5, 1.0), yaw half-way the short way round: 3 + (2 pi - 6) / 2 = pi -> -pi
    assert p[0, :2] == pytest.approx([0.5, 1.0]) and abs(wrap_angle(p[0, 2] - math.pi)) < 1e-9
    assert p[1] == pytest.approx([1.0, 2.0, -3.0]) and np.isnan(p[2]).all()


def test_relations_of_ground_truth_and_of_a_moved_copy_are_zero(tmp_path):
    gt = loop()
    rel = make_relations(gt, every_s=1.0)
    assert len(rel) == 20 and rel[0, :2].tolist() == [0.0, 1.0]
    write_relations(tmp_path / "a.relations", rel)
    np.testing.assert_allclose(read_relations(tmp_path / "a.relations"), rel, atol=1e-6)
    for est in (gt, moved(gt, (5.0, 1.0, 2.0))):       # the metric ignores the estimate's frame
        r = relations_error(est, rel)
        assert r.used == 20 and r.missing == 0
        assert r.trans_mean_m < 1e-9 and r.rot_mean_deg < 1e-7
    by_distance = make_relations(gt, every_m=1.0)
    # the circle is 4 pi = 12.57 m long, poses 0.0628 m apart: 1 m takes 16 poses -> 12 relations
    assert len(by_distance) == 12


def test_relations_metric_on_known_perturbations():
    # A straight line at 1 m/s, relations every 1 m.
    t = np.arange(0.0, 10.05, 0.1)
    gt = np.column_stack([t, t, np.zeros_like(t), np.zeros_like(t)])
    rel = make_relations(gt, every_s=1.0)
    # (a) every heading off by eps: the relative yaws are right, each 1 m step points eps off:
    # error translation |R(-eps) - I| * 1 m = 2 sin(eps / 2), rotation 0
    eps = 0.1
    est = gt.copy()
    est[:, 3] += eps
    r = relations_error(est, rel)
    assert r.used == 10 and r.trans_mean_m == pytest.approx(2 * math.sin(eps / 2)) and r.rot_mean_deg < 1e-9
    assert r.trans_std_m == pytest.approx(0.0, abs=1e-12)
    assert r.trans_sq_mean_m2 == pytest.approx(4 * math.sin(eps / 2) ** 2)
    # (b) turning in place at 0.5 rad/s, estimated 0.6 rad/s: each 1 s relation is 0.1 rad off
    # (5.7296 deg, squared 32.828 deg^2), no translation
    spin = np.column_stack([t, np.zeros_like(t), np.zeros_like(t), wrap_angle(0.5 * t)])
    est = np.column_stack([t, np.zeros_like(t), np.zeros_like(t), wrap_angle(0.6 * t)])
    r = relations_error(est, make_relations(spin, every_s=1.0))
    assert r.rot_mean_deg == pytest.approx(math.degrees(0.1)) and r.trans_mean_m == 0.0
    assert r.rot_sq_mean_deg2 == pytest.approx(math.degrees(0.1) ** 2)
    # (c) one relation of ten 0.2 m too long, the others exact: mean 0.2 / 10 = 0.02 m,
    # sample std sqrt((9 * 0.02^2 + 0.18^2) / 9) = 0.0632 m
    est = gt.copy()
    est[t > 5.05, 1] += 0.2          # a jump between the poses at 5.0 s and 6.0 s
    r = relations_error(est, rel)
    assert r.trans_mean_m == pytest.approx(0.02) and r.trans_std_m == pytest.approx(0.063246, abs=1e-6)


def test_relations_error_is_cartographers():
    # Expected: 1 m straight ahead. Estimated: 1 m straight ahead, but turned 0.1 rad on the way.
    # Cartographer: error = (pose1⁻¹ pose2) expected⁻¹ = (R(0.1), (1, 0) - R(0.1) (1, 0)):
    # translation 2 sin(0.05) = 0.09996 m (expected⁻¹ (pose1⁻¹ pose2) would give 0), rotation 0.1 rad
    rel = np.array([[0.0, 1.0, 1.0, 0.0, 0.0]])
    est = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.1]])
    trans, rot = relation_errors(est, rel)
    assert trans == pytest.approx([2 * math.sin(0.05)]) and rot == pytest.approx([0.1])


def test_relations_outside_the_estimate_are_counted_missing():
    gt = loop()
    rel = make_relations(gt, every_s=1.0)
    r = relations_error(gt[gt[:, 0] <= 10.0], rel)
    assert (r.used, r.missing) == (10, 10)
    with pytest.raises(ValueError, match="none of the 20 relations"):
        relations_error(gt[gt[:, 0] <= 0.5], rel)


def run_cli(*args):
    return subprocess.run([sys.executable, str(CLI), *map(str, args)], capture_output=True, text=True, timeout=60)


def test_cli(tmp_path):
    gt = loop()
    est = gt.copy()
    est[:, 1] += 0.1
    write_tum(tmp_path / "gt.tum", gt)
    write_tum(tmp_path / "est.tum", est)
    write_relations(tmp_path / "gt.relations", make_relations(gt, every_s=2.0))
    out = run_cli("--traj", tmp_path / "est.tum", "--gt", tmp_path / "gt.tum", "--relations",
                  tmp_path / "gt.relations", "--json", tmp_path / "r.json")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ATE: rmse 0.1000 m") and "relations (10 used, 0 outside" in out.stdout
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["ate_rmse_m"] == pytest.approx(0.1) and report["relations_used"] == 10
    assert report["relations_trans_mean_m"] == pytest.approx(0.0, abs=1e-6)
    # --align: a moved copy scores ~0
    write_tum(tmp_path / "moved.tum", moved(gt, (1.0, 2.0, 0.5)))
    out = run_cli("--traj", tmp_path / "moved.tum", "--gt", tmp_path / "gt.tum", "--align")
    assert out.returncode == 0 and out.stdout.startswith("ATE: rmse 0.0000 m")
    # bad input: one line on stderr, status 1; bad arguments: argparse's 2
    (tmp_path / "junk.tum").write_text("hello world\n")
    for args, why in [(("--traj", tmp_path / "none.tum", "--gt", tmp_path / "gt.tum"), "No such file"),
                      (("--traj", tmp_path / "junk.tum", "--gt", tmp_path / "gt.tum"), "junk.tum:1:"),
                      (("--traj", tmp_path / "est.tum", "--gt", tmp_path / "gt.tum", "--relations",
                        tmp_path / "junk.tum"), "junk.tum:1:")]:
        out = run_cli(*args)
        assert out.returncode == 1 and out.stdout == ""
        assert why in out.stderr and out.stderr.count("\n") == 1 and out.stderr.startswith("slam_eval: ")
    assert run_cli("--traj", tmp_path / "est.tum").returncode == 2
