#!/usr/bin/env python3
"""rostest node for explore_small.test: waits (wall time) for the evaluator's report.json of
this run (written after the node started) and checks it: the share of the reachable free
space F that the map marks known >= min_seen, coverage (DESIGN §6: marked free) >=
min_coverage and 90 % reached within budget_s of sim time, the explorer finished by itself
(not by the budget), no collision, the run output next to the report, and (if ~strategy is
given) the strategy the report names."""
import json
import os
import time
import unittest

import rospy
import rostest

STARTED = time.time()


def wait_for_report(path: str, wait_s: float):
    """The report at ``path`` once one newer than this node exists (None after ``wait_s``)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline and not rospy.is_shutdown():
        try:
            if os.path.getmtime(path) >= STARTED:
                time.sleep(0.5)                      # let the writer finish the file
                with open(path) as f:
                    return json.load(f)
        except (OSError, ValueError):
            pass
        time.sleep(0.5)
    return None


class ExploreSmall(unittest.TestCase):
    def test_full_exploration(self):
        path = rospy.get_param("~report")
        budget_s = float(rospy.get_param("~budget_s"))
        min_coverage = float(rospy.get_param("~min_coverage"))
        min_seen = float(rospy.get_param("~min_seen"))
        report = wait_for_report(path, float(rospy.get_param("~wait_wall_s")))
        self.assertIsNotNone(report, f"no report.json at {path} from this run")
        summary = {k: report.get(k) for k in ("coverage_final", "coverage_seen_final", "F_marked_occupied",
                                              "time_to_90_s", "time_to_95_s", "distance_m", "collisions",
                                              "sim_time_s", "wall_time_s", "finished_reason")}
        rospy.loginfo("explore_small: %s", summary)
        self.assertGreaterEqual(report["coverage_seen_final"], min_seen, summary)
        self.assertGreaterEqual(report["coverage_final"], min_coverage, summary)
        self.assertIsNotNone(report["time_to_90_s"], summary)
        self.assertLessEqual(report["time_to_90_s"], budget_s, summary)
        self.assertNotIn("budget", report["finished_reason"], summary)
        self.assertEqual(report["collisions"], 0, summary)
        self.assertGreater(report["distance_m"], 1.0, summary)
        if rospy.has_param("~strategy"):
            self.assertEqual(report["strategy"], rospy.get_param("~strategy"))
        out = os.path.dirname(path)
        for name in ("map.yaml", "map.pgm", "map.png", "coverage.png", "report.md"):
            self.assertTrue(os.path.exists(os.path.join(out, name)), name)


if __name__ == "__main__":
    rospy.init_node("explore_small_test")
    rostest.rosrun("turtlebot_recon", "explore_small", ExploreSmall)
