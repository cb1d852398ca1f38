"""explore_robot.launch resolved by roslaunch's own loader (no master, no node started): the
topics each robot's nodes end up on. A real robot's drivers fix these names, so a wrong default
is a robot that never moves or never sees a tag."""
import pytest
import roslaunch.config
import roslaunch.xmlloader

from turtlebot_recon.paths import SHARE_DIR

LAUNCH = str(SHARE_DIR / "launch" / "explore_robot.launch")


def nodes(**args):
    argv = [f"{k}:={v}" for k, v in args.items()]
    config = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(LAUNCH, config, argv=argv, verbose=False)
    return {n.name: dict(n.remap_args) for n in config.nodes}


@pytest.mark.parametrize("robot, image, info", [
    ("turtlebot2", "/camera/rgb/image_raw", "/camera/rgb/camera_info"),   # Astra/Kinect driver
    ("turtlebot3_waffle_pi", "/camera/image_raw", "/camera/camera_info"),
])
def test_camera_topics_follow_the_robot(robot, image, info):
    remaps = nodes(robot=robot, mission="tags")["tag_detector"]
    assert remaps.get("image") == image and remaps.get("camera_info") == info, remaps


def test_turtlebot2_drives_the_kobuki_topics():
    graph = nodes(robot="turtlebot2")
    assert graph["navigator"]["cmd_vel"] == "/mobile_base/commands/velocity"
    assert graph["explorer"]["cmd_vel"] == "/mobile_base/commands/velocity"
    # its bringup (minimal.launch) publishes the model, so ours does not start
    assert "robot_state_publisher" not in graph


def test_turtlebot3_gets_our_robot_model():
    assert "robot_state_publisher" in nodes(robot="turtlebot3_burger")


def test_tools_read_the_one_default_robot():
    # tools/launch's mission check and tools/slam_log.py take the robot explore_sim.launch defaults to
    from turtlebot_recon.paths import launch_defaults
    sim = launch_defaults("explore_sim.launch")
    assert sim["robot"] == "turtlebot3_waffle_pi" and sim["world"] == "house"
    assert "robot" not in launch_defaults("explore_robot.launch")   # a real robot must be named
