"""Run output: report.json / report.md (DESIGN §6 keys), the coverage and map plots, and the
evaluator's core: its run log, the report of a run and the run directory (report.json last)."""
import json
import math
import os

import cv2
import numpy as np
import pytest

from turtlebot_recon.evaluation import (CoverageTracker, plot_coverage, plot_map, reachable_free_space,
                                        write_report)
from turtlebot_recon.evaluation.coverage import wall_face
from turtlebot_recon.evaluation import report as report_module
from turtlebot_recon.evaluation.trajectory_metrics import read_tum
from turtlebot_recon.evaluation.metrics import standing
from turtlebot_recon.evaluation.evaluator import (RUN_FILES, EvaluatorSettings, FinalMap, RunLog, run_report,
                                                  summary_line, write_run)
from turtlebot_recon.evaluation.report import REPORT_KEYS, full_report, map_figure_size_px, markdown
from turtlebot_recon.mapping.map_io import load_map, save_map
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim import load_world

DESIGN_KEYS = [
    "world", "robot", "strategy", "seed", "coverage_final", "time_to_90_s", "time_to_95_s",
    "time_to_99_s", "map_precision_occupied", "map_precision_free", "ate_m", "tags_placed",
    "tags_confirmed", "tag_recall", "tag_error_median_m", "tag_error_max_m", "false_tags",
    "distance_m", "collisions", "sim_time_s", "wall_time_s", "rtf", "finished_reason",
]
TAB_BLUE = (31, 119, 180)      # matplotlib's tab:blue, the driven path (RGB)


def rgb(path):
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert img is not None, path
    return img[..., ::-1]


def count_colour(img, colour, tol=12):
    return int(np.all(np.abs(img.astype(int) - colour) <= tol, axis=2).sum())


def test_report_keys_are_designs():
    assert list(REPORT_KEYS) == DESIGN_KEYS


def test_report_json_has_every_key_nulls_and_extras(tmp_path):
    report = {
        "world": "house", "robot": "turtlebot3_waffle_pi", "strategy": "recon",
        "seed": np.int64(3), "coverage_final": np.float64(0.9925), "time_to_90_s": 312.5,
        "time_to_95_s": 401.0, "time_to_99_s": None, "ate_m": float("nan"),
        "collisions": 0, "rtf": 14.2, "finished_reason": "no frontiers | home",
        "cpu_percent": {"mapper": np.float32(12.5)}, "goals": np.array([1, 2]),
    }
    json_path, md_path = write_report(tmp_path / "run", report)
    assert json_path == tmp_path / "run" / "report.json" and md_path.name == "report.md"
    data = json.loads(json_path.read_text())
    # The 23 DESIGN keys first, in order, then the 2 extras as given.
    assert list(data) == DESIGN_KEYS + ["cpu_percent", "goals"]
    assert data["seed"] == 3 and data["coverage_final"] == 0.9925
    assert data["time_to_99_s"] is None            # never reached
    assert data["ate_m"] is None                   # NaN is not JSON: null
    assert data["tags_placed"] is None and data["map_precision_free"] is None   # missing
    assert data["collisions"] == 0                 # a zero stays a zero, not null
    assert data["cpu_percent"] == {"mapper": 12.5} and data["goals"] == [1, 2]
    assert "NaN" not in json_path.read_text()


def test_report_md_is_a_table_with_units(tmp_path):
    _, md_path = write_report(tmp_path, {"world": "office", "robot": "turtlebot2",
                                         "coverage_final": 0.975, "time_to_90_s": 123.456,
                                         "distance_m": 87.25, "finished_reason": "a | b",
                                         "note": "extra"})
    md = md_path.read_text()
    lines = md.splitlines()
    assert lines[0] == "# Run report: office · turtlebot2"
    rows = {line.split("`")[1]: line for line in lines if line.startswith("| ") and "`" in line}
    assert list(rows) == DESIGN_KEYS
    # Fractions in per cent: 0.975 -> 97.50 %; times to 0.1 s: 123.456 -> 123.5 s.
    assert rows["coverage_final"] == "| coverage of reachable free space, final | 97.50 | % | `coverage_final` |"
    assert "| 123.5 | s |" in rows["time_to_90_s"]
    assert "| 87.250 | m |" in rows["distance_m"]
    assert "| — |" in rows["ate_m"] and "| m |" in rows["ate_m"]       # missing: a dash
    assert "a \\| b" in rows["finished_reason"]   # an escaped pipe keeps the table's 4 cells
    assert "| note | extra |" in md


def test_plot_coverage_png(tmp_path):
    # 800 x 450 px (8 x 4.5 in at 100 dpi). The curve is tab:blue; a tracker-like object and a
    # (t, fraction) pair draw the same picture.
    t = np.linspace(0.0, 600.0, 121)
    frac = 1.0 - np.exp(-t / 120.0)   # 90 / 95 / 99 % at 120 ln(10, 20, 100) = 276, 359, 553 s
    path = plot_coverage(tmp_path / "plots" / "coverage.png", (t, frac), "house")
    img = rgb(path)
    assert img.shape == (450, 800, 3)
    assert count_colour(img, TAB_BLUE) > 300

    class Tracker:
        series = (t, frac)

    path2 = plot_coverage(tmp_path / "coverage2.png", Tracker(), "house")
    assert np.array_equal(rgb(path2), img)
    # Never reaching 90 %, and an empty series, still draw.
    assert rgb(plot_coverage(tmp_path / "low.png", (t, 0.5 * frac), "")).shape == (450, 800, 3)
    assert rgb(plot_coverage(tmp_path / "empty.png", ([], []), "")).shape == (450, 800, 3)


def test_plot_map_png(tmp_path):
    # A 64 x 84-cell map (0.05 m: 4.2 x 3.2 m): longer side 84 cells -> 900 px, so 900 + 150 =
    # 1050 px wide and round(64 * 900 / 84) = round(685.7) = 686 + 120 = 806 px high.
    occ = np.full((64, 84), -1, np.int8)
    occ[2:62, 2:60] = 0
    occ[:, 60] = 100
    assert map_figure_size_px(occ.shape) == (1050, 806)
    path_xy = np.column_stack([np.linspace(0.3, 2.5, 50), 1.0 + 0.5 * np.sin(np.linspace(0, 6, 50))])
    goals = [(1.0, 1.0), (2.5, 1.5)]
    path = plot_map(tmp_path / "map.png", occ, 0.05, (-1.0, -0.5), path_xy=path_xy,
                    goals_xy=goals, tags=[{"id": 4, "x": 2.0, "y": 2.0}, (5, 0.5, 2.5)])
    img = rgb(path)
    assert img.shape == (806, 1050, 3)
    # Free white, occupied black, unknown grey (0.62 * 255 = 158) all appear, and the path.
    assert count_colour(img, (255, 255, 255), 2) > 50_000
    assert count_colour(img, (0, 0, 0), 2) > 1_000
    assert count_colour(img, (158, 158, 158), 2) > 50_000
    assert count_colour(img, TAB_BLUE) > 200
    # Without a path (or goals, tags) nothing is drawn in the path's colour.
    bare = rgb(plot_map(tmp_path / "bare.png", occ, 0.05, (-1.0, -0.5)))
    assert bare.shape == (806, 1050, 3)
    assert count_colour(bare, TAB_BLUE) == 0
    # A tall map: 200 rows x 50 cols -> 900 px high, round(50 * 4.5) = 225 px wide.
    assert map_figure_size_px((200, 50)) == (225 + 150, 900 + 120)


# ------------------------------------------------------------------ report.json: last, whole

def spy_on_replace(monkeypatch, on_replace):
    """Call ``on_replace(src, dst)`` just before each os.replace (the file is not there yet)."""
    real = os.replace

    def replace(src, dst, *args, **kwargs):
        on_replace(str(src), str(dst))
        return real(src, dst, *args, **kwargs)
    monkeypatch.setattr(os, "replace", replace)          # files.write_atomic's


def test_write_report_writes_report_json_last_and_whole(tmp_path, monkeypatch):
    report = {"world": "house", "robot": "turtlebot2", "coverage_final": 0.5, "note": "x" * 10_000}
    (tmp_path / "report.json").write_text('{"world": "old run"}\n')
    seen = []

    def at_replace(src, dst):
        # report.md is complete and the new report.json is still a temporary file beside it.
        assert os.path.dirname(src) == str(tmp_path) and dst == str(tmp_path / "report.json")
        assert (tmp_path / "report.md").read_text() == markdown(report)
        assert json.loads((tmp_path / "report.json").read_text()) == {"world": "old run"}
        assert json.loads(open(src).read()) == full_report(report)
        seen.append(sorted(os.listdir(tmp_path)))
    spy_on_replace(monkeypatch, at_replace)
    json_path, md_path = write_report(tmp_path, report)
    assert len(seen) == 1 and len(seen[0]) == 3                       # json, md and the temporary
    assert sorted(os.listdir(tmp_path)) == ["report.json", "report.md"]   # the temporary is gone
    assert json.loads(json_path.read_text()) == full_report(report)
    assert md_path.stat().st_mtime_ns <= json_path.stat().st_mtime_ns
    assert oct(json_path.stat().st_mode & 0o777) == oct(md_path.stat().st_mode & 0o777)   # as any file


def test_a_failed_write_leaves_no_partial_report_json(tmp_path, monkeypatch):
    def fail(src, dst):
        raise OSError("disk full")
    spy_on_replace(monkeypatch, fail)
    with pytest.raises(OSError, match="disk full"):
        write_report(tmp_path, {"world": "house"})
    assert sorted(os.listdir(tmp_path)) == ["report.md"]                 # no report.json, no temporary
    # A value JSON cannot hold fails before any file is written.
    monkeypatch.undo()
    with pytest.raises(TypeError):
        write_report(tmp_path / "bad", {"world": object()})
    assert not (tmp_path / "bad").exists() or os.listdir(tmp_path / "bad") == []


# ------------------------------------------------------------------ the evaluator's core

START = (1.0, 1.5, 0.0)       # room_world's start pose: map frame = world - (1, 1.5)


@pytest.fixture
def run(room_world):
    """A run in the 4 x 3 m room (F = its 4800 free cells) with a hand-made log:
    truth  t = 9 (1, 1.5) before the clock starts at t = 10; t = 10 there; t = 11 (1.01, 1.5),
           0.01 m on, too close to keep (path_step_m 0.02) but driven; t = 12 (2, 1.5);
           t = 13 (2, 2.5). distance 0.01 + 0.99 + 1 = 2 m; path kept: t 9, 12, 13, in the
           map frame (t - 10, x - 1, y - 1.5): (-1, 0, 0), (2, 1, 0), (3, 1, 1).
    collision at t = 13.5 (count 0 -> 1) at the last true position (2, 2.5): (1, 1) m, 3.5 s.
    goals  (1, 0), (1, 0) again (not counted), (1, 1): 2.
    ATE    estimate (0.03, 0.04) vs truth (1, 1.5) -> (0, 0): 0.05^2; (1, 0) vs (2, 1.5) -> (1, 0):
           0. RMSE sqrt(0.0025 / 2) = 0.035355 m.
    coverage samples: half the room known at 1 s (0.5), all at 3 s (1.0): 90/95/99 % at 3 s.
    final map: the world grid with column 42 of the room marked occupied and column 43 unknown."""
    world = load_world(room_world)
    robot = load_robot("turtlebot3_burger")
    coverage = CoverageTracker(world, reachable_free_space(world, robot, robot.lidar.range_max_m))
    log = RunLog(world.start, 0.02)
    log.truth(9.0, 1.0, 1.5)
    assert log.start_clock(10.0) and not log.start_clock(11.0)
    for t, x, y in ((10.0, 1.0, 1.5), (11.0, 1.01, 1.5), (12.0, 2.0, 1.5), (13.0, 2.0, 2.5)):
        log.truth(t, x, y)
    assert log.collision_count(0, 12.5) is None
    assert log.collision_count(1, 13.5) == (1.0, 1.0, 3.5)
    assert log.collision_count(1, 14.0) is None
    for g in ((1.0, 0.0), (1.0, 0.0), (1.0, 1.0)):
        log.goal(g)
    log.ate_sample((0.03, 0.04), (1.0, 1.5), t_s=10.0, estimate_yaw=0.1)
    log.ate_sample((1.0, 0.0), (2.0, 1.5), t_s=12.0)
    occ = world.occupancy()
    origin = (world.origin[0] - START[0], world.origin[1] - START[1])
    half = occ.copy()
    half[:, 42:] = -1
    coverage.update(1.0, half, 0.05, origin)
    coverage.update(3.0, occ, 0.05, origin)
    occ[2:62, 42], occ[2:62, 43] = 100, -1          # rows 2..61: the room's
    final = FinalMap(occ, 0.05, origin, yaml_path="/runs/x/map.yaml")
    return world, robot, coverage, log, final


def test_run_log_keeps_the_path_on_the_report_clock(run):
    _, _, _, log, _ = run
    assert log.distance_m == pytest.approx(2.0)
    np.testing.assert_allclose(log.path_in_map(), [[-1.0, 0.0, 0.0], [2.0, 1.0, 0.0], [3.0, 1.0, 1.0]], atol=1e-12)
    assert log.goals == [(1.0, 0.0), (1.0, 1.0)] and log.collisions == 1
    assert log.ate_m() == pytest.approx(math.sqrt(0.0025 / 2))
    assert RunLog(START, 0.02).ate_m() is None


def test_run_report_from_the_log_coverage_and_map(run):
    world, robot, coverage, log, final = run
    report = run_report(EvaluatorSettings(seed=7), world, robot, coverage, log, end_s=20.0, wall_time_s=4.0,
                        reason="no frontiers", strategy="recon", final_map=final)
    # Map precision: occupied = the 64 x 84 - 4800 = 576 wall cells (solid: precise) and column
    # 42's 60 room cells, of which rows 2, 3, 60, 61 lie within 1.5 cells of a wall (clearance
    # 0.5 or 1.5 cells): 580 / 636. The 4800 - 120 cells marked free are all truly free.
    # Seen: all of F known but column 43 (60 cells), column 42 occupied: 0.9875 and 0.0125.
    assert report == {
        "world": "room", "robot": "turtlebot3_burger", "seed": 7, "strategy": "recon",
        "coverage_final": 1.0, "time_to_90_s": 3.0, "time_to_95_s": 3.0, "time_to_99_s": 3.0,
        "map_precision_occupied": pytest.approx(580 / 636), "map_precision_free": 1.0,
        "coverage_seen_final": pytest.approx(0.9875), "F_marked_occupied": pytest.approx(0.0125),
        "ate_m": pytest.approx(0.035355, abs=1e-6),
        "tags_placed": None, "tags_confirmed": None, "tag_recall": None, "tag_error_median_m": None,
        "tag_error_max_m": None, "false_tags": None, "tag_search_s": None,
        "landmarks": None, "landmark_error_median_m": None, "landmark_error_max_m": None, "false_landmarks": None,
        "distance_m": 2.0, "collisions": 1,
        "sim_time_s": 10.0, "wall_time_s": 4.0, "rtf": 2.5, "finished_reason": "no frontiers",
        "ate_odometry_m": pytest.approx(0.035355, abs=1e-6),   # no SLAM: the odometry is the estimate
        "map_frame": "odom",
        "distance_to_99_m": 2.0,          # along the kept points until t = 3 s: 1 + 1
        # from the clock's start (t = 10) to 99 % (t = 13): 0.01 m/s from t = 10 to 11 stands,
        # before any move (no stop)
        "time_standing_s": 1.0, "stops": 0,
        "F_cells": 4800, "F_m2": 12.0, "goals": 2, "ate_samples": 2,
        "sim_start_s": 10.0, "map": "/runs/x/map.yaml", "collisions_at": [(1.0, 1.0, 3.5)],
    }
    assert "room · turtlebot3_burger · recon | coverage 100.0 % (90 % at 3 s" in summary_line(report)
    assert "| 2.0 m driven | standing 1 s, 0 stops |" in summary_line(report)
    # Without a map: precision and seen unknown (null), no map file.
    bare = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 0.0, "shut down", None)
    assert "coverage_seen_final" not in bare and bare["map"] is None and bare["rtf"] is None
    assert full_report(bare)["map_precision_free"] is None
    with pytest.raises(ValueError, match="clock never started"):
        run_report(EvaluatorSettings(), world, robot, coverage, RunLog(START, 0.02), 1.0, 1.0, "x", None)


def check_run_file(path):
    """Whether a run file is whole: images decode, CSVs parse under their header, Markdown ends
    with report.md's closing line, JSON parses. Returns what it read."""
    name = os.path.basename(path)
    if name.endswith(".png"):
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        assert img is not None, name
        return img.shape
    if name.endswith(".csv"):
        with open(path) as f:
            header = f.readline().strip()
        return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).shape
    if name.endswith(".md"):
        text = open(path).read()
        assert text.endswith("(null in report.json).\n"), name
        return len(text)
    if name.endswith(".tum"):
        return read_tum(path).shape
    return json.loads(open(path).read())


def test_write_run_writes_every_file_before_report_json(run, tmp_path, monkeypatch):
    world, robot, coverage, log, final = run
    report = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon", final)
    out = tmp_path / "run"
    out.mkdir()
    (out / "report.json").write_text('{"world": "an earlier run"}\n')   # removed before anything is written
    at_replace = {}

    def snapshot(src, dst):
        if os.path.basename(dst) == "report.json":
            assert not os.path.exists(dst)
            at_replace.update({n: check_run_file(str(out / n)) for n in os.listdir(out) if n != os.path.basename(src)})
    spy_on_replace(monkeypatch, snapshot)
    json_path = write_run(out, report, coverage, log, final)
    assert json_path == out / "report.json"
    # When report.json appears, every other file is there and whole.
    assert at_replace == {
        "coverage.csv": ("sim_time_s,coverage", (2, 2)),
        "path.csv": ("sim_time_s,x_m,y_m", (3, 3)),
        "ground_truth.tum": (5, 4),                  # every truth sample, not one per path_step_m
        "estimate.tum": (2, 4),                      # the live estimate at each ATE sample
        "coverage.png": (450, 800, 3),
        "map.png": (*map_figure_size_px(final.occupancy.shape)[::-1], 3),
        "report.md": len(markdown(report)),
    }
    assert sorted(os.listdir(out)) == sorted((*RUN_FILES, "estimate.tum"))
    np.testing.assert_allclose(read_tum(out / "estimate.tum"), [[10.0, 0.03, 0.04, 0.1], [12.0, 1.0, 0.0, 0.0]], atol=1e-6)
    assert json.loads(json_path.read_text()) == full_report(report)
    np.testing.assert_allclose(np.loadtxt(out / "path.csv", delimiter=",", skiprows=1), log.path_in_map(), atol=1e-3)
    # No final map and no coverage sample: no map.png, no coverage.png; report.json still last.
    empty = CoverageTracker(world, reachable_free_space(world, robot, robot.lidar.range_max_m))
    write_run(tmp_path / "bare", report, empty, RunLog(START, 0.02))
    assert sorted(os.listdir(tmp_path / "bare")) == ["coverage.csv", "ground_truth.tum", "path.csv", "report.json",
                                                     "report.md"]


def test_tag_metrics_match_by_marker_set_and_id_and_count_false_tags():
    from turtlebot_recon.evaluation.metrics import tag_metrics
    truth = [("tag36h11", 1, 0.0, 0.0, 0.25), ("tag36h11", 2, 5.0, 0.0, 0.25), ("aruco_6x6_100", 1, 2.0, 2.0, 0.2)]
    est = [("tag36h11", 1, 0.03, 0.0, 0.25),         # 3 cm off
           ("aruco_6x6_250", 1, 2.0, 2.01, 0.2),     # the same marker under a larger dictionary
           ("tag36h11", 2, 3.0, 0.0, 0.25),          # 2 m off: false
           ("tag36h11", 9, 1.0, 1.0, 0.25)]          # no such tag: false
    m = tag_metrics(truth, est)
    assert m == {"tags_placed": 3, "tags_confirmed": 4, "tag_recall": pytest.approx(2 / 3, abs=1e-4),
                 "tag_error_median_m": pytest.approx(0.02), "tag_error_max_m": pytest.approx(0.03),
                 "false_tags": 2}
    assert tag_metrics(truth, [])["tag_recall"] == 0.0


# ------------------------------------------------------------------ tags on map.png, tag_search_s

TAB_CYAN, TAB_PURPLE, RED = (23, 190, 207), (148, 103, 189), (255, 0, 0)   # estimates, true tags, false tags


def spy_on_figures(monkeypatch):
    """The figures plot_map saves, in order (each saved as usual)."""
    figures = []
    real = report_module._save

    def save(fig, path_png):
        figures.append(fig)
        return real(fig, path_png)
    monkeypatch.setattr(report_module, "_save", save)
    return figures


def lines_by_label(fig):
    (ax,) = fig.axes
    return {line.get_label(): line for line in ax.get_lines()}


def test_plot_map_draws_true_tags_hollow_estimates_filled_and_false_tags_red(tmp_path, monkeypatch):
    from turtlebot_recon.evaluation.metrics import tag_metrics
    occ = np.full((64, 84), -1, np.int8)
    occ[2:62, 2:82] = 0
    truth = [("tag36h11", 1, 0.5, 2.0, 0.25), ("aruco_6x6_100", 7, 2.0, 0.5, 0.2), ("tag36h11", 3, 2.5, 2.4, 0.25)]
    est = [("tag36h11", 1, 0.53, 2.0, 0.25),        # 3 cm off: matched
           ("aruco_6x6_250", 7, 2.0, 0.56, 0.2),    # the same marker set and id: matched
           ("tag36h11", 3, 1.5, 2.4, 0.25),         # 1 m off (> FALSE_TAG_M): false
           ("tag36h11", 9, 0.2, 0.2, 0.25)]         # no such true tag: false
    # The plot's matches are tag_metrics' (2 matched, 2 false).
    assert report_module.match_tags(truth, est) == [0, 1, None, None]
    assert tag_metrics(truth, est)["false_tags"] == 2
    figures = spy_on_figures(monkeypatch)
    img = rgb(plot_map(tmp_path / "map.png", occ, 0.05, (-1.0, -0.5), tags=est, true_tags=truth))
    assert img.shape == (806, 1050, 3)
    lines = lines_by_label(figures[-1])
    assert set(lines) == {"true tags (3)", "tag error (estimate to true)", "estimated tags (2 matched)",
                          "false tags (2)"}
    true_line, estimated, false = lines["true tags (3)"], lines["estimated tags (2 matched)"], lines["false tags (2)"]
    assert true_line.get_markerfacecolor() == "none" and true_line.get_linestyle() == "None"     # hollow
    np.testing.assert_allclose(true_line.get_xydata(), [[0.5, 2.0], [2.0, 0.5], [2.5, 2.4]])
    assert estimated.get_markerfacecolor() not in ("none", None)                                   # filled
    np.testing.assert_allclose(estimated.get_xydata(), [[0.53, 2.0], [2.0, 0.56]])
    np.testing.assert_allclose(false.get_xydata(), [[1.5, 2.4], [0.2, 0.2]])
    assert false.get_markerfacecolor() == "red"
    # One segment from each matched estimate to its true tag, NaN between them.
    np.testing.assert_allclose(lines["tag error (estimate to true)"].get_xydata(),
                               [[0.53, 2.0], [0.5, 2.0], [np.nan, np.nan], [2.0, 0.56], [2.0, 0.5],
                                [np.nan, np.nan]])
    legend = figures[-1].axes[0].get_legend()
    assert legend is not None and {t.get_text() for t in legend.get_texts()} == set(lines)
    # On the PNG: the true tags' purple, the estimates' cyan and the false tags' red.
    assert count_colour(img, TAB_PURPLE) > 50 and count_colour(img, TAB_CYAN) > 20 and count_colour(img, RED) > 20
    # Estimates without the truth are not judged: no true tags, no red, no error lines.
    plot_map(tmp_path / "est.png", occ, 0.05, (-1.0, -0.5), tags=est)
    assert set(lines_by_label(figures[-1])) == {"estimated tags (4)"}
    assert count_colour(rgb(tmp_path / "est.png"), RED) == 0
    # The truth alone (nothing confirmed): every true tag hollow, nothing else.
    plot_map(tmp_path / "truth.png", occ, 0.05, (-1.0, -0.5), tags=[], true_tags=truth)
    assert set(lines_by_label(figures[-1])) == {"true tags (3)"}
    assert figures[-1].axes[0].get_xlim() == pytest.approx((-1.0, 3.2))        # the map's extent
    # A tag off the robot's map (here a true one not explored yet) stays in view, 0.4 m from the edge.
    far = truth + [("tag36h11", 4, 5.0, -1.0, 0.25)]
    assert rgb(plot_map(tmp_path / "far.png", occ, 0.05, (-1.0, -0.5), tags=est, true_tags=far)).shape == img.shape
    ax = figures[-1].axes[0]
    assert ax.get_xlim() == pytest.approx((-1.0, 5.4))
    assert ax.get_ylim() == pytest.approx((-1.4, 2.8))      # the top: tag 3's y 2.4 + 0.4
    assert "true tags (4)" in lines_by_label(figures[-1])
    # No tags at all: no tag artist, no legend, none of the tag colours.
    bare = rgb(plot_map(tmp_path / "bare.png", occ, 0.05, (-1.0, -0.5)))
    assert lines_by_label(figures[-1]) == {} and figures[-1].axes[0].get_legend() is None
    assert count_colour(bare, TAB_CYAN) == count_colour(bare, TAB_PURPLE) == count_colour(bare, RED) == 0


def test_write_run_draws_the_worlds_tags_and_the_confirmed_ones(run, tmp_path, monkeypatch):
    import dataclasses

    from turtlebot_recon.evaluation import evaluator as evaluator_module
    from turtlebot_recon.sim.world import Tag
    world, robot, coverage, log, final = run
    # Two tags on the room's walls (world frame; the map frame is the world less (1, 1.5)).
    world = dataclasses.replace(world, tags=(
        Tag(id=4, family="tag36h11", x=4.1, y=1.5, z=0.25, yaw=math.pi, size=0.16),
        Tag(id=5, family="tag36h11", x=2.0, y=3.1, z=0.25, yaw=-math.pi / 2, size=0.16)))
    truth = evaluator_module.true_tags(world)
    assert truth == [("tag36h11", 4, pytest.approx(3.1), pytest.approx(0.0), 0.25),
                     ("tag36h11", 5, pytest.approx(1.0), pytest.approx(1.6), 0.25)]
    calls = []
    real = evaluator_module.plot_map

    def plot_map_spy(*args, **kwargs):
        calls.append(kwargs)
        return real(*args, **kwargs)
    monkeypatch.setattr(evaluator_module, "plot_map", plot_map_spy)
    est = [("tag36h11", 4, 3.08, 0.01, 0.25), ("tag36h11", 8, 2.0, 1.0, 0.25)]
    report = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon", final, est)
    assert report["tags_placed"] == 2 and report["false_tags"] == 1
    write_run(tmp_path / "tags", report, coverage, log, final, tags=est, world=world)
    assert calls[-1]["tags"] == est and calls[-1]["true_tags"] == truth
    # No tag tracker (tags None): no tags on the map, the world's neither.
    write_run(tmp_path / "no_tags", report, coverage, log, final, world=world)
    assert calls[-1]["tags"] is None and calls[-1]["true_tags"] is None
    assert sorted(os.listdir(tmp_path / "no_tags")) == sorted((*RUN_FILES, "estimate.tum"))


def test_tag_search_s_counts_from_the_first_tags_phase(run, tmp_path):
    world, robot, coverage, log, final = run
    assert log.phase("map", 10.0) and log.phase("tags", 15.5)
    assert not log.phase("tags", 18.0)                       # only the first "tags" counts
    assert log.phases == {"map": 10.0, "tags": 15.5}
    report = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon", final, tags=[])
    assert report["tag_search_s"] == 4.5                     # end 20 - 15.5
    data = json.loads(write_report(tmp_path, report)[0].read_text())
    # An extra key, after the DESIGN keys and the map's two extras.
    assert data["tag_search_s"] == 4.5
    assert list(data)[len(DESIGN_KEYS):len(DESIGN_KEYS) + 3] == ["coverage_seen_final", "F_marked_occupied",
                                                                 "tag_search_s"]
    assert "| tag_search_s | 4.5 |" in markdown(report)
    # No tag tracker, or no "tags" phase (an explorer without one): null.
    assert run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon", final)[
        "tag_search_s"] is None
    log.phases.clear()
    assert log.phase("map", 10.0)
    assert run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon", final, tags=[])[
        "tag_search_s"] is None


def test_standing_time_and_stops_on_a_synthetic_trajectory():
    # 10 Hz samples along x from t = 0: stand 2 s; drive 0.2 m/s 3 s; stand 1 s (t 5..6); drive
    # 1 s; stand 0.2 s; drive 0.8 s; stand 0.6 s, a 0.1 s twitch at 0.3 m/s, stand 0.6 s (t
    # 8..9.3); drive 1 s; stand 0.3 s; drive 1 s.
    speeds = [0.0] * 20 + [0.2] * 30 + [0.0] * 10 + [0.2] * 10 + [0.0] * 2 + [0.2] * 8 \
        + [0.0] * 6 + [0.3] + [0.0] * 6 + [0.2] * 10 + [0.0] * 3 + [0.2] * 10
    t = np.arange(len(speeds) + 1) * 0.1
    x = np.concatenate([[0.0], np.cumsum(np.asarray(speeds) * 0.1)])
    poses = np.column_stack([t, x, np.zeros_like(x), np.zeros_like(x)])
    # Standing: 2 + 1 + 0.2 + 1.2 + 0.3 = 4.7 s. Stops: the 1 s stand and the stand with the
    # twitch in it (one stop, not two: the twitch is no start); the 0.2 and 0.3 s stands are
    # too short, the stand at the start follows no move.
    total, stops = standing(poses, 0.0, t[-1])
    assert total == pytest.approx(4.7) and stops == 2
    # The window: to t = 6 s, the first stands only; from 1.5 s, half a second of the first.
    total, stops = standing(poses, 0.0, 6.0)
    assert total == pytest.approx(3.0) and stops == 1
    total, stops = standing(poses, 1.5, 6.0)
    assert total == pytest.approx(1.5) and stops == 1
    # A creep at 0.04 m/s stands; at 0.06 m/s it moves.
    creep = np.column_stack([t[:11], 0.004 * np.arange(11), np.zeros(11)])
    assert standing(creep, 0.0, 1.0)[0] == pytest.approx(1.0)
    assert standing(creep * [1.0, 1.5, 1.0], 0.0, 1.0)[0] == 0.0
    assert standing(np.zeros((1, 3)), 0.0, 1.0) == (0.0, 0)


def test_slams_landmarks_are_scored_in_x_y_against_the_worlds_tags(tmp_path):
    from turtlebot_recon.evaluation.evaluator import landmark_report, true_tags
    from turtlebot_recon.sim.world import Tag
    import dataclasses
    world = load_world("house")
    world = dataclasses.replace(world, tags=(Tag(3, "tag36h11", 2.0, 3.0, 0.25, 0.0, 0.16),
                                             Tag(4, "tag36h11", 5.0, 3.0, 0.25, 0.0, 0.16)))
    (_, _, x3, y3, _), (_, _, x4, y4, _) = true_tags(world)          # in the map frame
    # the graph is 2-D: its z (0) must not count against the tags' 0.25 m
    got = landmark_report(world, [("tag36h11", 3, x3 + 0.03, y3 - 0.04, 0.0),
                                  ("tag36h11", 4, x4 + 0.01, y4, 0.0),
                                  ("tag36h11", 9, x4, y4, 0.0)])            # no such tag: false
    assert got == {"landmarks": 3, "landmark_error_median_m": 0.03, "landmark_error_max_m": 0.05,
                   "false_landmarks": 1}
    assert set(landmark_report(world, None).values()) == {None}           # no SLAM graph


def test_the_final_coverage_reads_the_live_map_whose_undecided_wall_faces_the_saved_file_drops(run, tmp_path):
    """A wall face the lidar hit about as often as it passed reads 26..64 on /map: observed, so
    covered (DESIGN §6); map_saver's trinary file writes it unknown. The evaluator's last sample
    reads the map its other samples read (``covered_map``: /map), precision the saved file: the
    maze's SLAM runs lost 1.2 % of coverage at the end to that file alone."""
    world, robot, coverage, log, _ = run
    occ = world.occupancy()
    origin = (world.origin[0] - START[0], world.origin[1] - START[1])
    live = occ.copy()
    live[wall_face(world)] = 50
    assert coverage.covered(live, 0.05, origin).all()
    saved = load_map(save_map(tmp_path / "map", live, 0.05, origin))
    assert not coverage.covered(saved[0], saved[1], saved[2])[coverage.face].any()
    report = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon",
                        FinalMap(*saved, yaml_path="map.yaml"), covered_map=FinalMap(live, 0.05, origin))
    assert report["coverage_seen_final"] == 1.0 and report["F_marked_occupied"] == 0.0
    assert report["map_precision_free"] == 1.0 and report["map"] == "map.yaml"
    without = run_report(EvaluatorSettings(), world, robot, coverage, log, 20.0, 4.0, "done", "recon",
                         FinalMap(*saved, yaml_path="map.yaml"))
    assert without["coverage_seen_final"] == pytest.approx(1.0 - coverage.face.mean())
