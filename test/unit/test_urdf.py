"""The robot model (urdf/turtlebot.urdf.xacro) is built from config/robots/*.yaml: each robot's
sensor frames, body and wheels in the URDF equal its YAML, so the two cannot drift apart."""
import math
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from turtlebot_recon.robot import CONFIG_DIR, load_robot

TOP = Path(__file__).resolve().parents[2]
XACRO = TOP / "urdf" / "turtlebot.urdf.xacro"
ROBOTS = sorted(p.stem for p in CONFIG_DIR.glob("*.yaml"))


def urdf(robot_yaml: Path) -> ET.Element:
    """The URDF as robot_description.launch makes it: the xacro command with robot_yaml:=."""
    exe = shutil.which("xacro")
    assert exe, "xacro not on PATH (tools/requirements.txt installs it in the venv)"
    out = subprocess.run([exe, str(XACRO), f"robot_yaml:={robot_yaml}"], check=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True).stdout
    return ET.fromstring(out)


def numbers(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def frames(root: ET.Element) -> dict:
    """Every link's pose in base_footprint as a 4x4 matrix, composed along the joints."""
    joints = {}
    for j in root.iter("joint"):
        assert j.get("type") == "fixed", f"joint {j.get('name')} is {j.get('type')}: nothing publishes joint_states"
        o = j.find("origin")
        t = np.eye(4)
        t[:3, :3] = rpy_matrix(*numbers(o.get("rpy", "0 0 0")))
        t[:3, 3] = numbers(o.get("xyz", "0 0 0"))
        joints[j.find("child").get("link")] = (j.find("parent").get("link"), t)
    poses = {"base_footprint": np.eye(4)}

    def pose(link):
        if link not in poses:
            parent, t = joints[link]
            poses[link] = pose(parent) @ t
        return poses[link]

    for link in root.iter("link"):
        pose(link.get("name"))
    return poses


@pytest.mark.parametrize("name", ROBOTS)
def test_sensor_frames_equal_the_robot_yaml(name):
    robot = load_robot(name)
    root = urdf(CONFIG_DIR / f"{name}.yaml")
    poses = frames(root)
    parents = {j.find("child").get("link"): j.find("parent").get("link") for j in root.iter("joint")}
    # DESIGN §3: base_footprint -> base_link -> the sensors
    assert parents["base_link"] == "base_footprint"
    assert parents[robot.lidar.frame_id] == "base_link"
    assert poses["base_link"][:3, 3] == pytest.approx([0, 0, 0.010])
    lidar = poses[robot.lidar.frame_id]
    assert lidar[:3, 3] == pytest.approx([robot.lidar.x_m, robot.lidar.y_m, robot.lidar.z_m], abs=1e-9)
    assert lidar[:3, :3] == pytest.approx(np.eye(3))
    assert "imu_link" in poses       # the frame of sim_bridge's /imu
    if robot.camera is None:
        assert "camera_link" not in poses
        return
    c = robot.camera
    cam, optical = poses[c.frame_id], poses[c.optical_frame_id]
    assert parents[c.frame_id] == "base_link" and parents[c.optical_frame_id] == c.frame_id
    assert cam[:3, 3] == pytest.approx([c.x_m, c.y_m, c.z_m], abs=1e-9)
    assert optical[:3, 3] == pytest.approx(cam[:3, 3], abs=1e-12)
    # REP-103's optical frame: z forward, x right, y down (columns: its axes in base_footprint)
    assert optical[:3, :3] == pytest.approx(np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]]), abs=1e-12)
    # the depth camera (TurtleBot 2) is registered to the RGB one: its optical frame is the same
    # pose, beside camera_optical under the camera's frame; the TurtleBot 3s have none
    d = robot.depth_camera
    assert (d is not None) == (name == "turtlebot2")
    if d is not None:
        assert parents[d.optical_frame_id] == c.frame_id and d.optical_frame_id != c.optical_frame_id
        assert poses[d.optical_frame_id] == pytest.approx(optical, abs=1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_body_and_wheels_equal_the_robot_yaml(name):
    robot = load_robot(name)
    root = urdf(CONFIG_DIR / f"{name}.yaml")
    poses = frames(root)
    body = root.find("./link[@name='base_link']/visual")
    top = poses["base_link"][2, 3] + 2 * float(body.find("origin").get("xyz").split()[2])
    assert top == pytest.approx(robot.body_height_m)
    if robot.is_round:
        assert float(body.find("geometry/cylinder").get("radius")) == pytest.approx(robot.radius_m)
    else:
        size = numbers(body.find("geometry/box").get("size"))
        assert size[:2] == pytest.approx([robot.footprint_length_m, robot.footprint_width_m])
        assert float(body.find("origin").get("xyz").split()[0]) == pytest.approx(robot.footprint_offset_x_m)
    for side, sign in (("left", 1), ("right", -1)):
        wheel = poses[f"wheel_{side}_link"][:3, 3]
        assert wheel == pytest.approx([0, sign * 0.5 * robot.wheel_separation_m, robot.wheel_radius_m])
        cyl = root.find(f"./link[@name='wheel_{side}_link']/visual/geometry/cylinder")
        assert float(cyl.get("radius")) == pytest.approx(robot.wheel_radius_m)


def test_a_changed_yaml_changes_the_model(tmp_path):
    """The numbers are read from the YAML given, not copied into the model."""
    spec = yaml.safe_load((CONFIG_DIR / "turtlebot3_waffle_pi.yaml").read_text())
    spec["lidar"].update(frame_id="laser", x_m=0.05, z_m=0.3)
    spec["camera"]["y_m"] = 0.02
    path = tmp_path / "moved.yaml"
    path.write_text(yaml.safe_dump(spec))
    poses = frames(urdf(path))
    assert poses["laser"][:3, 3] == pytest.approx([0.05, 0.0, 0.3])
    assert "base_scan" not in poses
    assert poses["camera_link"][1, 3] == pytest.approx(0.02)
