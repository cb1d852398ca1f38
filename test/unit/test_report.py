"""Run output: report.json / report.md (DESIGN §6 keys) and the coverage and map plots."""
import json

import cv2
import numpy as np

from turtlebot_recon.evaluation import plot_coverage, plot_map, write_report
from turtlebot_recon.evaluation.report import REPORT_KEYS, map_figure_size_px

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
