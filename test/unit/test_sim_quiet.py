"""The simulator keeps pybullet's own C prints (build time, EGL driver lines, the EGL window's
goodbye) off the console: a run's console is for the nodes' progress lines."""
import subprocess
import sys

SCRIPT = """
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim.simulator import SimSettings, Simulator
from turtlebot_recon.sim.world import load_world
sim = Simulator(load_world("house"), load_robot("turtlebot3_waffle_pi"), SimSettings(camera_rate_hz=5.0, seed=2))
sim.render_camera()
sim.close()
print("only this")
"""


def test_pybullet_prints_nothing_through_a_pipe():
    # a pipe, as roslaunch's screen output: C's stdio buffers there, which once let the text out late
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "only this\n", proc.stdout
    assert "pybullet" not in proc.stderr and "EGL" not in proc.stderr, proc.stderr
