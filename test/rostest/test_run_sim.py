"""The `make` targets' launcher (tools/launch) end to end: `make wander`'s launch file drives the
house and writes its report; a bad argument is refused before any node starts; a node that
fails ends the run non-zero with the node's own message as the last line."""
import fcntl
import json
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest

from conftest import node_pid

TOP = Path(__file__).resolve().parents[2]
RED = "\x1b[31m"


def launch(*args, port: str, timeout: float = 300.0, auto: bool = True) -> subprocess.CompletedProcess:
    """tools/launch with a master of its own on the loopback address (no host name needed);
    ``auto``: as tools/env.sh leaves it when the user named no master (the port is ours to
    choose), else as when the user set ROS_MASTER_URI."""
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1",
               TURTLEBOT_RECON_MASTER="auto")
    env.pop("ROS_HOSTNAME", None)
    if not auto:
        env.pop("TURTLEBOT_RECON_MASTER")
    return subprocess.run([str(TOP / "tools" / "launch"), *args], env=env, timeout=timeout,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_wander_writes_report_and_ends_quietly(tmp_path):
    proc = launch("--tag", "wander", "--done", "scripted_drive", "--report", str(tmp_path / "report.json"),
                  "run_sim.launch", "world:=house", "robot:=turtlebot3_burger", "rtf:=0", "duration:=30",
                  f"output:={tmp_path}", "end_with_driver:=false", port="11477")
    lines = proc.stdout.strip().splitlines()
    tail = "\n".join(lines[-30:])
    assert proc.returncode == 0, tail
    assert lines[-1] == f"[wander] done: the report is in {tmp_path} (report.json and the files next to it)", tail
    assert RED not in proc.stdout, "a good run printed a red line:\n" + tail
    # roslaunch's own chatter stays off the terminal: no parameter summary, no process lines
    assert "PARAMETERS" not in proc.stdout and "process[" not in proc.stdout, proc.stdout[:3000]
    assert any("scripted_drive" in ln for ln in lines[:-1]), tail      # the nodes' own lines stay
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


def test_bad_arguments_are_refused_before_any_node_starts(tmp_path):
    bad_world = tmp_path / "w.yaml"
    bad_world.write_text("image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    cases = [("world:=no_such_world", "WORLD=no_such_world refused", "house"),
             (f"world:={bad_world}", f"WORLD={bad_world} refused", "nowhere.pgm"),
             ("robot:=turtlebot4", "ROBOT=turtlebot4 refused", "turtlebot3_burger"),
             ("strategy:=recn", "STRATEGY=recn refused", "explore_lite"),
             ("planner:=rrt", "PLANNER=rrt refused", "ompl_rrtconnect"),
             ("octomap:=yes", "OCTOMAP=yes refused", "true or false")]
    for arg, refusal, choice in cases:
        proc = launch("--done", "evaluator", "explore_sim.launch", arg, port="11478", timeout=60)
        lines = proc.stdout.strip().splitlines()
        assert proc.returncode == 2, proc.stdout
        assert len(lines) == 1 and refusal in lines[0] and choice in lines[0], proc.stdout
        assert "process[" not in proc.stdout     # nothing was started


def test_a_failing_node_ends_the_run_with_its_own_message():
    proc = launch("--tag", "sim", "sim.launch", "odom_slip:=-1", "camera_rate:=0", "rtf:=0", port="11479",
                  timeout=120)
    last = proc.stdout.strip().splitlines()[-1]
    assert proc.returncode == 1, proc.stdout[-3000:]
    assert last.startswith("[sim] failed: node sim_bridge exited with status 1:"), last
    assert "odom_slip_std_sqrt_m: must be >= 0" in last, last


def busy_port() -> socket.socket:
    """A listening socket on a free loopback port: another run's master, as tools/launch sees it."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    return s


def test_a_run_whose_port_is_taken_gets_a_master_of_its_own(tmp_path):
    """Issue 32: a second `make run` joined the first one's master and its nodes replaced the
    first run's. Where the port is ours to choose, a taken one gives way to a free one, said in
    one line, and the run goes on to its report."""
    with busy_port() as taken:
        port = taken.getsockname()[1]
        proc = launch("--tag", "wander", "--done", "scripted_drive", "--report", str(tmp_path / "report.json"),
                      "run_sim.launch", "world:=house", "robot:=turtlebot3_burger", "rtf:=0", "duration:=5",
                      f"output:={tmp_path}", "end_with_driver:=false", port=str(port))
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 0, "\n".join(lines[-20:])
    assert lines[0].startswith(f"[wander] port {port} is taken (another run?): this run's ROS master is at "
                               "http://127.0.0.1:"), lines[0]
    assert json.loads((tmp_path / "report.json").read_text())["sim_time_s"] >= 5.0
    assert not (tmp_path / ".run.lock").exists()          # the run directory is free again


def test_a_master_the_user_named_that_runs_already_is_refused(tmp_path):
    with busy_port() as taken:
        port = taken.getsockname()[1]
        proc = launch("--tag", "wander", "--done", "scripted_drive", "--report", str(tmp_path / "report.json"),
                      "run_sim.launch", "world:=house", f"output:={tmp_path}", port=str(port), auto=False,
                      timeout=60)
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stdout
    assert lines[0].startswith(f"[wander] refused: a ROS master (or another server) already listens at "
                               f"http://127.0.0.1:{port} (ROS_MASTER_URI)"), lines[0]


def test_a_run_directory_in_use_is_refused(tmp_path):
    with open(tmp_path / ".run.lock", "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        held.write("pid 4242\n")
        held.flush()
        proc = launch("--tag", "run", "--done", "evaluator", "--report", str(tmp_path / "report.json"),
                      "explore_sim.launch", f"output:={tmp_path}", port="11480", timeout=60)
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stdout
    assert lines[0] == (f"[run] refused: {tmp_path} is in use by another run (pid 4242); give this one "
                        "another OUTPUT=DIR"), lines[0]


# the explorer, not the navigator: a killed navigator is restarted (docs/faults.md, test_faults.py)
@pytest.mark.parametrize("node", ["explorer", "evaluator", "Ctrl-C"])
def test_a_node_killed_mid_run_is_named_in_the_report(tmp_path, node):
    """Issue 32, nothing lost: a node killed mid-run ends it loudly, and report.json names the
    node; where the evaluator itself died, tools/launch writes the report from what the other
    nodes saved; Ctrl-C (SIGINT to the terminal's process group) is named too."""
    with busy_port() as free:                 # a port free now; the master must be on it (not auto)
        port = free.getsockname()[1]
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    env.pop("TURTLEBOT_RECON_MASTER", None)
    proc = subprocess.Popen([str(TOP / "tools" / "launch"), "--tag", "run", "--done", "evaluator", "--report",
                             str(tmp_path / "report.json"), "explore_sim.launch", "world:=arena",
                             "robot:=turtlebot3_burger", "mission:=map", "rtf:=0", "budget:=600",
                             f"output:={tmp_path}", "end_with_evaluator:=false"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and not any("explorer: started" in ln for ln in lines):
            time.sleep(0.5)
        time.sleep(3.0)                                   # a few cycles of exploring
        if node == "Ctrl-C":
            os.killpg(proc.pid, signal.SIGINT)
        else:
            pid = node_pid(node, port)
            assert pid is not None, f"no {node} running: {''.join(lines[-20:])}"
            os.kill(pid, signal.SIGKILL)
        proc.wait(timeout=120)
        reader.join(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    out = "".join(lines)
    last = out.strip().splitlines()[-1]
    if node == "Ctrl-C":
        assert proc.returncode == 130 and last.startswith("[run] stopped (Ctrl-C); report: "), out[-3000:]
        report = json.loads((tmp_path / "report.json").read_text())
        assert report["finished_reason"] == "stopped by Ctrl-C", report["finished_reason"]
        assert report["coverage_final"] > 0.05 and (tmp_path / "path.csv").exists()
        return
    assert proc.returncode == 1, out[-3000:]
    assert last.startswith(f"[run] failed: node {node} exited with status -9"), last
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["finished_reason"].startswith(f"node {node} exited with status -9"), report["finished_reason"]
    if node == "evaluator":
        assert report["written_by"] == "tools/launch: the evaluator wrote no report" and report["coverage_final"] is None
        assert report["world"] == "arena" and report["robot"] == "turtlebot3_burger"
        assert "(partial report: " in last
    else:
        assert report["finished_reason_evaluator"] == "shut down before the end"
        assert report["coverage_final"] > 0.05 and (tmp_path / "path.csv").exists()
        assert "(report: " in last
