#!/usr/bin/env python3
"""SLAM over a recorded log, faster than real time (``make slam-log LOG=FILE OUTPUT=DIR``).

    tools/slam_log.py --log FILE --output DIR [--robot NAME] [--config YAML] [--map YAML [--initial-pose X Y YAW]]

FILE is a rosbag (``.bag``: /scan, /odom, optional /imu) or a CARMEN log (FLASER, ROBOTLASER1,
ODOM lines). DIR receives trajectory.tum (the pose at every scan, sorted by stamp: what the relations
metric scores), keyframes.tum (the optimised keyframes), odometry.tum, map.pgm/.yaml and
graph.g2o. The robot's YAML gives the wheel separation (odometry noise model) and, for a bag,
the lidar's mounting. SLAM parameters: the ``slam:`` block of config/slam.yaml unless --config.
With --map (``make slam-log MAP=...``) the log is tracked in that saved map instead (mode
localization, the ``localization:`` block): DIR receives trajectory.tum (the pose at every
match) and odometry.tum. A log or a map that cannot be used: one line saying why, exit status 1.
A run stopped before the log's end by any error still writes what it has, says in one line
where it stopped, and exits with status 1; a log with bad lines is read around them (the
summary counts them) and ends with status 0.
"""
import argparse
import sys
from pathlib import Path

try:
    import turtlebot_recon  # noqa: F401  (found through the devel space: source tools/env.sh)
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from turtlebot_recon import paths
from turtlebot_recon.config import ConfigError, from_dict, load_yaml
from turtlebot_recon.robot import load_robot
from turtlebot_recon.ros.bags import read_log
from turtlebot_recon.slam.logs import LogError
from turtlebot_recon.slam.offline import localize_log, run_log
from turtlebot_recon.slam.node_settings import SlamNodeSettings

CONFIG = Path(__file__).resolve().parents[1] / "config" / "slam.yaml"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="slam_log", description=__doc__.split("\n\n")[0])
    p.add_argument("--log", required=True, help="rosbag (.bag) or CARMEN log")
    p.add_argument("--output", required=True, help="directory for the results")
    robot = paths.launch_defaults("explore_sim.launch")["robot"]   # the simulator's one default robot
    p.add_argument("--robot", default=robot, help=f"robot YAML name or path (default {robot})")
    p.add_argument("--config", default=str(CONFIG), help="slam parameters (config/slam.yaml)")
    p.add_argument("--map", help="localise in this saved map (map_server YAML) instead of mapping")
    p.add_argument("--initial-pose", nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar=("X", "Y", "YAW"),
                   help="with --map: the start pose in the map (m, m, rad; default 0 0 0)")
    a = p.parse_args(argv)
    try:
        node = from_dict(SlamNodeSettings, load_yaml(a.config), a.config)
        robot = load_robot(a.robot)
        lid = robot.lidar
        if a.map:
            result = localize_log(read_log(a.log), a.map, a.output, node.localization, robot.wheel_separation_m,
                                  (lid.x_m, lid.y_m, 0.0), tuple(a.initial_pose),
                                  log=lambda line: print(line, file=sys.stderr))
        else:
            result = run_log(read_log(a.log), a.output, node.slam, robot.wheel_separation_m, (lid.x_m, lid.y_m, 0.0),
                             log=lambda line: print(line, file=sys.stderr))
    except (ConfigError, LogError, OSError, ValueError, KeyError, TypeError) as exc:
        print(f"slam_log: {exc}", file=sys.stderr)
        return 1
    if a.map:
        st = result.stats
        print(f"slam_log: {result.scans} scans, {st['updates']} matched to {a.map} ({st['fused']} fused, "
              f"{st['relocalised']} relocalisations); {result.log_seconds:.0f} s of log in "
              f"{result.wall_seconds:.1f} s ({result.speedup:.1f}x real time); written to {a.output}")
        return 0
    st = result.stats
    problems = "".join(f", {st[k]} {what}" for k, what in (
        ("scans_no_return", "without a return"), ("odom_jumps", "odometry jumps"),
        ("refused", "steps refused by iSAM2"), ("keyframes_dropped", "keyframes dropped")) if st.get(k))
    print(f"slam_log: {result.scans} scans ({result.scans_dropped} without odometry{problems}), {result.keyframes} "
          f"keyframes, loop closures {st['loop_accepted']} of {st['loop_tried']} accepted; {result.log_seconds:.0f} s "
          f"of log in {result.wall_seconds:.1f} s ({result.speedup:.1f}x real time); iSAM2 median "
          f"{st.get('isam2_ms_median', float('nan')):.1f} ms"
          + (f"; gyro scale error {100 * st['gyro_scale']:+.2f} %, bias {1e3 * st['gyro_bias_radps']:+.3f} mrad/s "
             f"(std {1e3 * st['gyro_bias_std_radps']:.3f})" if "gyro_scale" in st else "")
          + f"; {result.log_summary}; written to {a.output}")
    if result.stopped:
        print(f"slam_log: {result.stopped}; what it had is written to {a.output}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
