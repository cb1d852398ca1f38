#!/usr/bin/env python3
"""Simulator benchmark (`make bench-sim`): world load times and real-time factors.

1. Load time of every shipped world, the two real maps in ../shared/worlds and a generated
   1,000 x 1,700-pixel warehouse (clean, and speckled like a noisy SLAM map): parse + merge
   boxes + build the PyBullet world (with the camera's visual shapes, the slower case).
   Target: < 5 s for the warehouse.
2. Real-time factor of the sim_bridge node alone (rtf:=0, the scripted wander driving it),
   measured from /clock over a wall-clock window: burger (lidar only) and waffle_pi (camera at
   5 Hz) in house and office. Targets: >= 30x burger, >= 5x with the camera.
3. For reference, the same loop in-process without ROS (the simulator core alone).
"""
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import SHARED_WORLDS as SHARED, TOP, write  # noqa: E402

from turtlebot_recon.robot import load_robot  # noqa: E402
from turtlebot_recon.sim import load_world, worldgen  # noqa: E402
from turtlebot_recon.sim.simulator import SimSettings, Simulator  # noqa: E402

WINDOW_S = float(os.environ.get("BENCH_WINDOW_S", "20"))


def load_times(generated: dict) -> dict:
    worlds = {n: n for n in ("house", "maze", "office", "arena")}
    worlds.update({p.stem: p for p in sorted(SHARED.glob("*.yaml"))})
    worlds.update(generated)
    robot = load_robot("turtlebot3_waffle_pi")
    out = {}
    for name, path in worlds.items():
        t0 = time.perf_counter()
        sim = Simulator(load_world(path), robot, SimSettings(camera_rate_hz=5.0))
        out[f"load_s_{name}"] = time.perf_counter() - t0
        out[f"boxes_{name}"] = sim.wall_boxes
        sim.close()
    out["load_s_max"] = max(v for k, v in out.items() if k.startswith("load_s_"))
    return out


def core_rtf(world: str, robot: str, camera_hz: float, sim_s: float = 60.0) -> float:
    """The simulator core alone: steps, scans and camera frames as the bridge would read them."""
    sim = Simulator(load_world(world), load_robot(robot), SimSettings(camera_rate_hz=camera_hz))
    t0 = time.perf_counter()
    for k in range(int(sim_s * sim.settings.physics_hz)):
        if k % 10 == 0:
            sim.set_command(0.15, 0.3 if (k // 1000) % 2 else -0.3)
        due = sim.step()
        if "scan" in due:
            sim.scan()
        if "camera" in due:
            sim.render_camera()
    rtf = sim.time_s / (time.perf_counter() - t0)
    sim.close()
    return rtf


def bridge_rtf(world: str, robot: str, camera_hz: float) -> float:
    """sim_bridge at rtf:=0 with the scripted wander; RTF from /clock over WINDOW_S wall seconds."""
    import rospy
    from rosgraph_msgs.msg import Clock
    launch = subprocess.Popen(
        ["roslaunch", "turtlebot_recon", "run_sim.launch", f"world:={world}", f"robot:={robot}",
         "rtf:=0", "duration:=0", f"camera_rate:={camera_hz}"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        rospy.wait_for_message("/clock", Clock, timeout=60)
        time.sleep(3.0)                                   # warm up (first EGL frames are slow)
        c0, w0 = rospy.wait_for_message("/clock", Clock, timeout=10).clock.to_sec(), time.monotonic()
        time.sleep(WINDOW_S)
        c1, w1 = rospy.wait_for_message("/clock", Clock, timeout=10).clock.to_sec(), time.monotonic()
        return (c1 - c0) / (w1 - w0)
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        launch.wait(timeout=30)


def main():
    import rospy
    figures = {}
    with tempfile.TemporaryDirectory() as tmp:
        image, meta = worldgen.warehouse()
        worldgen.write_world(Path(tmp), "warehouse", image, meta)
        # The same map with 0.3 % of free pixels turned occupied, as a noisy SLAM map would be:
        # far more boxes to merge and build (the start and tags are left to the loader).
        speckled = image.copy()
        speckled[(image == 254) & (np.random.default_rng(0).random(image.shape) < 0.003)] = 0
        worldgen.write_world(Path(tmp), "speckled", speckled, {**meta, "tags": [], "start": None})
        figures.update(load_times({"warehouse_1000x1700": Path(tmp) / "warehouse.yaml",
                                   "warehouse_1000x1700_speckled": Path(tmp) / "speckled.yaml"}))
    for world in ("house", "office"):
        figures[f"core_rtf_burger_{world}"] = core_rtf(world, "turtlebot3_burger", 0.0)
        figures[f"core_rtf_waffle_pi_{world}"] = core_rtf(world, "turtlebot3_waffle_pi", 5.0)
    roscore = subprocess.Popen(["roscore", "-p", "11311"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        time.sleep(3.0)
        rospy.init_node("bench_sim", anonymous=True, disable_signals=True)
        for world in ("house", "office"):
            figures[f"rtf_burger_{world}"] = bridge_rtf(world, "turtlebot3_burger", 0.0)
            figures[f"rtf_waffle_pi_{world}"] = bridge_rtf(world, "turtlebot3_waffle_pi", 5.0)
    finally:
        rospy.signal_shutdown("done")
        os.killpg(roscore.pid, signal.SIGINT)
        roscore.wait(timeout=30)
    write("sim", figures)


if __name__ == "__main__":
    main()
