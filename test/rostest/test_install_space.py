"""The install space works on its own. `make build`'s build tree is installed (the install step
of `catkin_make install`, reusing the build) into the workspace's install/; then, in an
environment that has only install/setup.bash sourced (no devel space, no checkout on any path),
the core imports from there, slam and perception included (a package list written by hand once
left them out), and a node graph runs from there: explore_sim.launch with SLAM explores the house
for a short budget on its own master, every node from install/, and its evaluator's report shows
the robot mapped and moved."""
import json
import os
import re
import subprocess
from pathlib import Path

import pytest

TOP = Path(__file__).resolve().parents[2]
WS = Path(subprocess.run([str(TOP / "tools" / "ws-path")], check=True, stdout=subprocess.PIPE,
                         text=True).stdout.strip())
INSTALL = WS / "install"
PORT = "11483"
BUDGET_S = 40.0


@pytest.fixture(scope="module")
def install_space():
    proc = subprocess.run(["cmake", "--build", str(WS / "build"), "--target", "install"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert (INSTALL / "setup.bash").is_file()
    return INSTALL


def installed(command: str, ros_home: Path, timeout: float) -> subprocess.CompletedProcess:
    """``command`` in bash with the install space sourced into a clean environment: the venv
    first on PATH (its python runs the nodes and xacro), a master of its own on the loopback."""
    env = {"HOME": os.environ.get("HOME", "/root"), "LANG": "C.UTF-8", "PYTHONDONTWRITEBYTECODE": "1",
           "PATH": f"{TOP / '.venv' / 'bin'}:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
           "ROS_HOME": str(ros_home), "ROS_MASTER_URI": f"http://127.0.0.1:{PORT}", "ROS_IP": "127.0.0.1"}
    return subprocess.run(["bash", "-c", f"source {INSTALL}/setup.bash && {command}"], env=env,
                          cwd=ros_home, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=timeout)


def test_the_core_imports_from_the_install_space(install_space, tmp_path):
    code = ("import turtlebot_recon, turtlebot_recon.slam, turtlebot_recon.perception, turtlebot_recon._native; "
            "from turtlebot_recon.msg import BumperEvent; from turtlebot_recon.robot import CONFIG_DIR; "
            "from turtlebot_recon.sim.world import WORLDS_DIR; "
            "print(turtlebot_recon.slam.__file__); print(turtlebot_recon.perception.__file__); "
            "print(turtlebot_recon._native.__file__); print(CONFIG_DIR); print(WORLDS_DIR)")
    proc = installed(f"python -c '{code}' && rospack find turtlebot_recon", tmp_path, timeout=60)
    assert proc.returncode == 0, proc.stdout
    paths = proc.stdout.split()
    assert len(paths) == 6, proc.stdout
    for p in paths:
        assert p.startswith(str(install_space) + "/"), proc.stdout
    assert paths[3] == str(install_space / "share" / "turtlebot_recon" / "config" / "robots")
    assert (install_space / "share" / "turtlebot_recon" / "urdf" / "turtlebot.urdf.xacro").is_file()


def test_a_node_graph_runs_from_the_install_space(install_space, tmp_path):
    out = tmp_path / "run"
    proc = installed(f"roslaunch turtlebot_recon explore_sim.launch world:=house robot:=turtlebot3_burger "
                     f"slam:=true budget:={BUDGET_S} output:={out}", tmp_path, timeout=400)
    tail = proc.stdout[-4000:]
    assert proc.returncode == 0, tail
    # roslaunch's log names each node's executable: every one of ours is the installed copy
    log = "".join(p.read_text() for p in (tmp_path / "log").glob("*/roslaunch-*.log"))
    started = dict(re.findall(r"process\[(\w+)-\d+\]: args\[\['([^']+)'", log))
    ours = {name: path for name, path in started.items() if "/turtlebot_recon/" in path}
    assert {"sim_bridge", "mapper", "slam", "navigator", "explorer", "evaluator"} <= set(ours), started
    for path in ours.values():
        assert path.startswith(str(install_space / "lib" / "turtlebot_recon") + "/"), started
    assert started["robot_state_publisher"].endswith("/robot_state_publisher"), started
    report = json.loads((out / "report.json").read_text())
    assert report["robot"] == "turtlebot3_burger" and report["world"] == "house", tail
    assert report["sim_time_s"] >= BUDGET_S - 1.0, report
    # the mapper placed the scans through the robot model's frames (a few % of the house's F
    # from the first scans alone), and commands from the installed nodes moved the robot
    assert report["coverage_final"] > 0.03, report
    assert report["distance_m"] > 0.2, report
    # the SLAM node (turtlebot_recon.slam) ran and saved its trajectory at shutdown
    assert len((out / "trajectory.tum").read_text().splitlines()) > 5, tail
