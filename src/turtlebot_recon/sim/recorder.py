"""Record a simulated run as the logs a real robot leaves, with the ground truth beside them.

``record_run`` drives the simulator (the scripted wander of ``wander.py``, or a list of
velocity commands) for a given time and writes, in ``out_dir``:

- ``run.clf``: a CARMEN log, ROBOTLASER1 per scan (robot pose = the wheel odometry at the scan,
  laser pose = that pose with the lidar's mount offset) and ODOM at the odometry rate: the
  odometry drifts as the simulator's does (``odom_slip``, std per sqrt(m) of each wheel);
- ``run.bag`` (given a ``bag_writer``, such as ``ros.bags.write_rosbag``: the ROS layer's, kept
  out of the simulator): ``/scan``, ``/odom``, ``/imu`` of the same run;
- ``ground_truth.tum``: the true base pose in the odometry's frame, whose origin is the start
  pose (the project's map frame, ``evaluation.coverage.world_to_map``), at every scan and at
  ``ground_truth_rate_hz``; with ``odom_slip`` 0 it equals the odometry;
- ``odometry.tum``: the wheel odometry at every ODOM record.

Stamps are sim seconds from the simulator's start.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from ..evaluation.trajectory_metrics import write_tum
from ..geometry import between, compose
from ..robot import RobotSpec, load_robot
from ..slam.logs import ImuRecord, LaserRecord, OdomRecord, Record, write_carmen
from .simulator import SimSettings, Simulator
from .wander import WanderSettings, command, sectors
from .world import World, load_world

COMMAND_PERIOD_S = 0.1    # re-send the latest command like a controller (cmd_timeout_s is 0.5 s)

Command = Tuple[float, float, float]   # (duration s, linear m/s, angular rad/s)
BagWriter = Callable[[Path, Iterable[Record]], int]   # (path, records) -> messages written


@dataclass(frozen=True)
class RecordedRun:
    carmen: Path
    ground_truth: Path
    odometry: Path
    bag: Optional[Path]        # None without a bag_writer
    scans: int
    distance_m: float          # true distance driven
    collisions: int


def record_run(world: Union[str, Path, World], robot: Union[str, RobotSpec], seconds: float,
               seed: int = 0, odom_slip: float = 0.0, out_dir: Union[str, Path] = ".", odom_heading: str = "wheels",
               commands: Optional[Sequence[Command]] = None, bag_writer: Optional[BagWriter] = None) -> RecordedRun:
    """Drive ``seconds`` of sim time with the wander (or ``commands``, then stop) and write the
    logs; returns their paths. Without ``bag_writer``: no bag."""
    world = world if isinstance(world, World) else load_world(world)
    robot = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sim = Simulator(world, robot, SimSettings(rtf=0.0, odom_slip_std_sqrt_m=odom_slip, odom_heading=odom_heading,
                                              camera_rate_hz=0.0,
                                              seed=seed))
    try:
        records, truth, odom = _drive(sim, seconds, commands)
    finally:
        sim.close()
    run = RecordedRun(out / "run.clf", out / "ground_truth.tum", out / "odometry.tum", None,
                      sum(isinstance(r, LaserRecord) for r in records), sim.distance_m, sim.collisions)
    write_carmen(run.carmen, [r for r in records if not isinstance(r, ImuRecord)])
    write_tum(run.ground_truth, np.array([(t, *p) for t, p in sorted(truth.items())]))
    write_tum(run.odometry, np.array(odom))
    if bag_writer is not None:
        bag_writer(out / "run.bag", records)
        run = dataclasses.replace(run, bag=out / "run.bag")
    return run


def _drive(sim: Simulator, seconds: float, commands: Optional[Sequence[Command]]):
    """Step the simulator; (records in time order, {t: true pose in the start frame}, odometry rows)."""
    lid = sim.robot.lidar
    start = np.array(sim.world.start, float)
    wander, turn_dir = WanderSettings(), 1.0
    script = _schedule(commands) if commands is not None else None
    cmd = (0.0, 0.0)
    records, truth, odom = [], {}, []
    resend = max(1, round(COMMAND_PERIOD_S / sim.dt))
    for k in range(int(round(seconds / sim.dt))):
        if script is not None:
            cmd = _scripted(script, sim.time_s)
        if k % resend == 0:
            sim.set_command(*cmd)
        due = sim.step()
        t = sim.time_s
        o = (sim.odom.x, sim.odom.y, sim.odom.yaw)
        if "scan" in due:
            ranges = sim.scan()
            laser = tuple(float(v) for v in compose(o, (lid.x_m, lid.y_m, 0.0)))
            records.append(LaserRecord(t, ranges, lid.angle_min_rad, lid.angle_increment_rad, lid.range_min_m,
                                       lid.range_max_m, odom_pose=o, laser_pose=laser))
            if script is None:
                front, left, right = sectors(ranges, lid.angle_min_rad, lid.angle_increment_rad,
                                             lid.range_min_m, lid.range_max_m)
                v, w, turn_dir = command(front, left, right, turn_dir, wander)
                cmd = (v, w)
                sim.set_command(*cmd)
        if "odom" in due:
            records.append(OdomRecord(t, *o, sim.odom.v, sim.odom.w))
            odom.append((t, *o))
        if "imu" in due:
            records.append(ImuRecord(t, sim.gyro_rate))
        if "scan" in due or "ground_truth" in due:
            truth[t] = tuple(float(v) for v in between(start, sim.pose))
    return records, truth, odom


def _schedule(commands: Sequence[Command]) -> np.ndarray:
    """(n, 3) rows (end time s, linear, angular) of the command list."""
    c = np.asarray(commands, float).reshape(-1, 3)
    return np.column_stack([np.cumsum(c[:, 0]), c[:, 1], c[:, 2]])


def _scripted(schedule: np.ndarray, t: float) -> Tuple[float, float]:
    i = int(np.searchsorted(schedule[:, 0], t, side="right"))
    return (0.0, 0.0) if i >= len(schedule) else (float(schedule[i, 1]), float(schedule[i, 2]))
