#!/usr/bin/env python3
"""rostest node for explore_small.test (and explore_oracle.test): waits (wall time) for the
evaluator's report.json of this run (written after the node started) and checks it: the
share of the reachable free space F that the map marks known >= min_seen, coverage (DESIGN
§6: marked free) >= min_coverage and 90 % reached within budget_s of sim time, the explorer
finished by itself (not by the budget), no collision, and (if ~strategy is given) the
strategy the report names.

The evaluator writes report.json last and atomically, so the run directory is complete once
report.json exists: the moment it appears, every other file of the run is checked, without
waiting: there, written by this run, and whole (images decode, CSVs and the map YAML parse)."""
import json
import os
import time
import unittest

import cv2
import numpy as np
import rospy
import rostest
import yaml

STARTED = time.time()
POLL_S = 0.2
PNG_END = b"IEND\xaeB`\x82"          # a PNG's last chunk, with its CRC
# The run's other files: the mapper's saved map (asked for by the evaluator), then the evaluator's.
CSV_HEADERS = {"coverage.csv": "sim_time_s,coverage", "path.csv": "sim_time_s,x_m,y_m"}
RUN_FILES = ("map.yaml", "map.pgm", "map.png", "coverage.png", *CSV_HEADERS, "report.md")


def wait_for_report(path: str, wait_s: float):
    """The report at ``path`` once one newer than this node exists (None after ``wait_s``).
    It is read as soon as it appears: the evaluator renames it into place whole."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline and not rospy.is_shutdown():
        try:
            if os.path.getmtime(path) >= STARTED:
                with open(path) as f:
                    return json.load(f)
        except FileNotFoundError:
            pass
        time.sleep(POLL_S)
    return None


def check_whole(path: str) -> None:
    """Raise AssertionError (or a parser's error) unless the run file at ``path`` is complete."""
    name = os.path.basename(path)
    if name.endswith((".png", ".pgm")):
        assert cv2.imread(path, cv2.IMREAD_UNCHANGED) is not None, "does not decode"
        if name.endswith(".png"):
            with open(path, "rb") as f:
                assert f.read().endswith(PNG_END), "no IEND chunk at the end"
    elif name in CSV_HEADERS:
        with open(path) as f:
            text = f.read()
        assert text.startswith(CSV_HEADERS[name] + "\n") and text.endswith("\n"), "header or last line cut"
        rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        assert rows.shape[0] >= 1 and rows.shape[1] == CSV_HEADERS[name].count(",") + 1, f"rows {rows.shape}"
    elif name == "map.yaml":
        with open(path) as f:
            meta = yaml.safe_load(f)
        assert {"image", "resolution", "origin"} <= set(meta), f"keys {sorted(meta)}"
    elif name == "report.md":
        with open(path) as f:
            assert f.read().endswith("(null in report.json).\n"), "cut short"


def incomplete_run_files(out_dir: str) -> list:
    """The run's other files that are missing, from an earlier run, or not whole: 'name: why'."""
    problems = []
    for name in RUN_FILES:
        path = os.path.join(out_dir, name)
        try:
            if os.path.getmtime(path) < STARTED:
                problems.append(f"{name}: from an earlier run")
                continue
            check_whole(path)
        except Exception as exc:                 # missing, unreadable, cut short: all reported
            problems.append(f"{name}: {type(exc).__name__}: {exc}")
    return problems


class ExploreSmall(unittest.TestCase):
    def test_full_exploration(self):
        path = rospy.get_param("~report")
        budget_s = float(rospy.get_param("~budget_s"))
        min_coverage = float(rospy.get_param("~min_coverage"))
        min_seen = float(rospy.get_param("~min_seen"))
        report = wait_for_report(path, float(rospy.get_param("~wait_wall_s")))
        self.assertIsNotNone(report, f"no report.json at {path} from this run")
        incomplete = incomplete_run_files(os.path.dirname(path))     # right away: no waiting
        summary = {k: report.get(k) for k in ("coverage_final", "coverage_seen_final", "F_marked_occupied",
                                              "time_to_90_s", "time_to_95_s", "distance_m", "collisions",
                                              "collisions_at", "sim_time_s", "wall_time_s", "finished_reason")}
        rospy.loginfo("explore_small: %s", summary)
        self.assertEqual(incomplete, [], "report.json appeared before the rest of the run directory")
        self.assertGreaterEqual(report["coverage_seen_final"], min_seen, summary)
        self.assertGreaterEqual(report["coverage_final"], min_coverage, summary)
        self.assertIsNotNone(report["time_to_90_s"], summary)
        self.assertLessEqual(report["time_to_90_s"], budget_s, summary)
        self.assertNotIn("budget", report["finished_reason"], summary)
        self.assertEqual(report["collisions"], 0, summary)
        self.assertGreater(report["distance_m"], 1.0, summary)
        if rospy.has_param("~strategy"):
            self.assertEqual(report["strategy"], rospy.get_param("~strategy"))


if __name__ == "__main__":
    rospy.init_node("explore_small_test")
    rostest.rosrun("turtlebot_recon", "explore_small", ExploreSmall)
