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
4. Camera render cost (ms per frame, median of FRAMES turning frames, the TurtleBot 2 in the
   house): RGB at 640 x 480, 320 x 240, 160 x 120 with each renderer (egl, tiny); the depth
   image alone at its 160 x 120 (TinyRenderer, as the simulator renders it without the RGB
   camera); the RGB + depth pair from one render, over the RGB frame alone; and the bridge's
   depth messages (32FC1 image + 80 x 60 cloud) built from a frame.
   `bench_sim.py --render` runs this part alone.
"""
import dataclasses
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


FRAMES = 30


def _median_ms(fn, frames: int = FRAMES, turn=None) -> tuple:
    """(wall ms, CPU ms) of one call of ``fn``, medians over ``frames`` calls. The CPU time is
    the process's, all threads (llvmpipe renders on several): steadier on a shared machine."""
    fn()                                          # the first frame (EGL: context, shaders) apart
    wall, cpu = [], []
    for _ in range(frames):
        if turn is not None:
            turn()
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def _put(out: dict, name: str, ms: tuple) -> None:
    out[f"render_ms_{name}"], out[f"render_cpu_ms_{name}"] = ms


def render_ms() -> dict:
    """Section 4: ms per frame of each camera render (module docstring)."""
    from turtlebot_recon.perception.depth import DepthCamera
    from turtlebot_recon.ros import convert
    world, tb2 = load_world("house"), load_robot("turtlebot2")
    out = {}
    for renderer in ("egl", "tiny"):
        for w, h in ((640, 480), (320, 240), (160, 120)):
            robot = dataclasses.replace(tb2, camera=dataclasses.replace(tb2.camera, width_px=w, height_px=h),
                                        depth_camera=None)
            sim = Simulator(world, robot, SimSettings(camera_rate_hz=5.0, depth_rate_hz=0.0, camera_renderer=renderer))
            _put(out, f"rgb_{w}x{h}_{renderer}", _median_ms(sim.render_camera, turn=lambda: _turn(sim)))
            sim.close()
        sim = Simulator(world, tb2, SimSettings(camera_rate_hz=5.0, depth_rate_hz=2.5, camera_renderer=renderer))
        _put(out, f"rgb_and_depth_640x480_{renderer}", _median_ms(lambda: sim.render_views(True, True),
                                                                  turn=lambda: _turn(sim)))
        sim.close()
    sim = Simulator(world, tb2, SimSettings(camera_rate_hz=0.0, depth_rate_hz=2.5))   # depth alone: tiny
    dep = tb2.depth_camera
    _put(out, f"depth_{dep.width_px}x{dep.height_px}_alone", _median_ms(lambda: sim.render_views(False, True),
                                                                        turn=lambda: _turn(sim)))
    depth = sim.render_views(False, True)[1]
    cloud = DepthCamera(sim.depth_matrix(), dep.width_px, dep.height_px, SimSettings().depth_points_stride_px)
    out["depth_messages_ms"], _ = _median_ms(lambda: (
        convert.image_32fc1(depth, dep.optical_frame_id, 0.0),
        convert.point_cloud_xyz(cloud.optical_points(depth), *cloud.shape, dep.optical_frame_id, 0.0)))
    sim.close()
    return out


def _turn(sim) -> None:
    """A new view each frame: the robot turns 0.3 rad in place."""
    sim.pose[2] += 0.3


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
    if "--render" in sys.argv[1:]:
        write("sim_render", render_ms())
        return
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
    figures.update(render_ms())
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
