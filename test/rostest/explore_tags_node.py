#!/usr/bin/env python3
"""rostest node for explore_tags.test: waits (wall time) for this run's report.json and checks
the tags mission: every tag of the world confirmed within 0.10 m (tag_recall 1, the error
keys), no false tag, the tag search begun (tag_search_s) and ended by the explorer (not the
budget), no collision; tags.yaml and tags.csv, saved by the evaluator's call before
report.json, reload with the tracker's loader and list exactly the world's tags. With
``~max_mapping_s`` (explore_tags_saved_map.test: a map made before), the tag search must begin
within that many sim seconds of the explorer's start."""
import os
import unittest

import rospy
import rostest

from explore_small_node import wait_for_report
from turtlebot_recon.perception.families import marker_set
from turtlebot_recon.perception.tracker import CSV_HEADER, load_tags_yaml
from turtlebot_recon.sim import load_world


class ExploreTags(unittest.TestCase):
    def test_tags_mission(self):
        path = rospy.get_param("~report")
        report = wait_for_report(path, float(rospy.get_param("~wait_wall_s")))
        self.assertIsNotNone(report, f"no report.json at {path} from this run")
        keys = ("tags_placed", "tags_confirmed", "tag_recall", "tag_error_median_m", "tag_error_max_m",
                "false_tags", "tag_search_s", "coverage_final", "collisions", "collisions_at", "sim_time_s",
                "finished_reason")
        summary = {k: report.get(k) for k in keys}
        rospy.loginfo("explore_tags: %s", summary)
        self.assertEqual(report["tags_placed"], 3, summary)
        self.assertEqual(report["tag_recall"], 1.0, summary)
        self.assertEqual(report["false_tags"], 0, summary)
        self.assertLessEqual(report["tag_error_max_m"], 0.10, summary)
        self.assertIsNotNone(report["tag_search_s"], summary)
        self.assertNotIn("budget", report["finished_reason"], summary)
        self.assertEqual(report["collisions"], 0, summary)
        if rospy.has_param("~max_mapping_s"):
            self.assertGreaterEqual(report["coverage_final"], 0.99, summary)
            self.assertLessEqual(report["sim_time_s"] - report["tag_search_s"], float(rospy.get_param("~max_mapping_s")),
                                 summary)
        out = os.path.dirname(path)
        self.assertLessEqual(os.path.getmtime(os.path.join(out, "tags.yaml")), os.path.getmtime(path))
        with open(os.path.join(out, "tags.yaml")) as f:
            tracks = load_tags_yaml(f.read())
        world = load_world(report["world"] if os.path.isabs(report["world"]) else
                           os.path.join(os.path.dirname(__file__), "..", "worlds", report["world"] + ".yaml"))
        self.assertEqual(sorted((marker_set(t.family), t.id) for t in tracks),
                         sorted((marker_set(t.family), t.id) for t in world.tags))
        with open(os.path.join(out, "tags.csv")) as f:
            lines = f.read().splitlines()
        self.assertEqual(lines[0], CSV_HEADER)
        self.assertEqual(len(lines), 1 + len(tracks))


if __name__ == "__main__":
    rospy.init_node("explore_tags_test")
    rostest.rosrun("turtlebot_recon", "explore_tags", ExploreTags)
