"""`make run`'s launch file end to end: the wander drives the house, the mapper maps it, and
map.pgm/map.yaml/report.json land in the output directory."""
import json
import os
import subprocess


def test_run_sim_writes_report(tmp_path):
    port = "11477"   # a master of its own, away from any running roscore
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    proc = subprocess.run(
        ["roslaunch", "-p", port, "turtlebot_recon", "run_sim.launch", "world:=house",
         "robot:=turtlebot3_burger", "rtf:=0", "duration:=30", f"output:={tmp_path}"],
        env=env, timeout=300, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    tail = "\n".join(proc.stdout.splitlines()[-30:])
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["world"] == "house" and report["robot"] == "turtlebot3_burger", tail
    assert report["sim_time_s"] >= 30.0
    assert report["distance_m"] > 2.0          # it really drove (0.2 m/s cruise)
    assert report["rtf"] > 1.0                 # rtf:=0 runs faster than real time
    assert isinstance(report["collisions"], int)
    # the mapper saved its map there, and it is precise (perfect odometry)
    assert (tmp_path / "map.pgm").exists() and (tmp_path / "map.yaml").exists()
    assert report["map_precision_occupied"] >= 0.98 and report["map_precision_free"] >= 0.98
    assert report["mapped_free_m2"] > 5.0
