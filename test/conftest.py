"""Shared factories: small worlds written as real map_server files; a run's node by its master."""
import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

FREE, OCCUPIED, UNKNOWN = 254, 0, 205


def write_world(directory: Path, name: str, free: np.ndarray, resolution: float = 0.05,
                origin=(0.0, 0.0, 0.0), unknown: np.ndarray | None = None, **extra) -> Path:
    """Write ``free`` (bool grid, row 0 = smallest y) as NAME.pgm + NAME.yaml; return the YAML path."""
    img = np.where(free, FREE, OCCUPIED).astype(np.uint8)
    if unknown is not None:
        img[unknown] = UNKNOWN
    cv2.imwrite(str(directory / f"{name}.pgm"), np.flipud(img))
    meta = {"image": f"{name}.pgm", "resolution": resolution, "origin": list(origin), "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary", **extra}
    path = directory / f"{name}.yaml"
    path.write_text(yaml.safe_dump(meta))
    return path


def room(width_m: float, height_m: float, resolution: float = 0.05, wall_m: float = 0.1) -> np.ndarray:
    """A free rectangle of width x height metres inside walls ``wall_m`` thick."""
    w = int(round(width_m / resolution)) + 2 * int(round(wall_m / resolution))
    h = int(round(height_m / resolution)) + 2 * int(round(wall_m / resolution))
    k = int(round(wall_m / resolution))
    free = np.zeros((h, w), bool)
    free[k:h - k, k:w - k] = True
    return free


@pytest.fixture
def room_world(tmp_path):
    """A 4 x 3 m room, walls 0.1 m; the free area spans x, y in [0.1, 4.1] x [0.1, 3.1]."""
    return write_world(tmp_path, "room", room(4.0, 3.0), start=[1.0, 1.5, 0.0])


@pytest.fixture
def make_sim():
    """make_sim(world_path, robot_name, **settings) -> Simulator; closed after the test."""
    from turtlebot_recon.robot import load_robot
    from turtlebot_recon.sim import load_world
    from turtlebot_recon.sim.simulator import SimSettings, Simulator
    made = []

    def make(world, robot="turtlebot3_burger", **settings):
        settings.setdefault("camera_rate_hz", 0.0)
        settings.setdefault("depth_rate_hz", 0.0)
        sim = Simulator(load_world(world), load_robot(robot), SimSettings(**settings))
        made.append(sim)
        return sim

    yield make
    for sim in made:
        sim.close()


def drive(sim, linear, angular, seconds):
    """Hold a command for ``seconds`` of sim time (re-sent at 10 Hz like a controller)."""
    for k in range(int(round(seconds / sim.dt))):
        if k % 10 == 0:
            sim.set_command(linear, angular)
        sim.step()


def bresenham(a, b, include_end=True):
    """Cells of the Bresenham line a -> b, (row, col) pairs in order from a; b last, or left
    out with ``include_end=False`` (then a line from a cell to itself is empty).

    The plain-Python reference for the C++ walk (include/turtlebot_recon/bresenham.hpp): one
    step per cell along the major axis, max(|d row|, |d col|) steps, ties stepping both axes.
    """
    (r, c), (r1, c1) = (int(a[0]), int(a[1])), (int(b[0]), int(b[1]))
    ar, sr = abs(r1 - r), (1 if r < r1 else -1)
    ac, sc = abs(c1 - c), (1 if c < c1 else -1)
    err = ar - ac
    cells = []
    for _ in range(max(ar, ac) + (1 if include_end else 0)):
        cells.append((r, c))
        e2 = 2 * err
        if e2 >= -ac:
            err -= ac
            r += sr
        if e2 <= ar:
            err += ar
            c += sc
    return cells


def grid_traversal(x0, y0, x1, y1, include_end=True):
    """Cells (row, col) of the segment (x0, y0) -> (x1, y1), in cell units (cell (r, c) is the
    square c <= x < c + 1, r <= y < r + 1), every cell it passes through in order; the end
    cell last, or left out with ``include_end=False``.

    The plain-Python reference for the C++ walk (include/turtlebot_recon/grid_traversal.hpp,
    Amanatides & Woo): the same arithmetic in the same order, so the same cells; at a corner
    it steps in rows first."""
    r, c = math.floor(y0), math.floor(x0)
    rows_left, cols_left = abs(math.floor(y1) - r), abs(math.floor(x1) - c)
    sr, sc = (1 if y1 > y0 else -1), (1 if x1 > x0 else -1)
    dx, dy = x1 - x0, y1 - y0
    never = math.inf
    t_col = (math.floor(x0) + 1.0 - x0) / dx if dx > 0 else (math.floor(x0) - x0) / dx if dx < 0 else never
    t_row = (math.floor(y0) + 1.0 - y0) / dy if dy > 0 else (math.floor(y0) - y0) / dy if dy < 0 else never
    dt_col = 1.0 / abs(dx) if dx != 0 else never
    dt_row = 1.0 / abs(dy) if dy != 0 else never
    cells = []
    for _ in range(rows_left + cols_left + (1 if include_end else 0)):
        cells.append((r, c))
        if cols_left > 0 and (rows_left == 0 or t_col < t_row):
            c, t_col, cols_left = c + sc, t_col + dt_col, cols_left - 1
        elif rows_left > 0:
            r, t_row, rows_left = r + sr, t_row + dt_row, rows_left - 1
    return cells


def ray_cells(origin, radius, beams, shape):
    """Reference rays of the C++ visibility walker: for each of ``beams`` bearings, the cells
    (row, col, is_origin) of the Bresenham line from ``origin`` toward the point ``radius``
    cells away, in order, stopping beyond ``radius`` (centre to centre) or at the grid's edge.
    Callers decide which cells block the rest of a ray."""
    rows, cols = shape
    for k in range(beams):
        angle = 2.0 * math.pi * k / beams
        end = (math.floor(radius * math.sin(angle) + 0.5), math.floor(radius * math.cos(angle) + 0.5))
        ray = []
        for dr, dc in bresenham((0, 0), end):
            r, c = origin[0] + dr, origin[1] + dc
            if dr * dr + dc * dc > radius * radius or not (0 <= r < rows and 0 <= c < cols):
                break
            ray.append((r, c, (dr, dc) == (0, 0)))
        yield ray


# ---------------------------------------------------------------- controllers in closed loop

def drive_controller(controller, robot, occ, path, pose, seconds, goal_yaw=None, res=0.05):
    """Close the loop at 10 Hz between ``controller`` (the control contract) and a unicycle whose
    speeds follow the command within the robot's accelerations (10 substeps per period), on the
    grid ``occ`` (origin (0, 0)), until the controller reports arrived, blocked or no_path.
    Returns (the poses of every substep (n, 3), the outputs)."""
    from turtlebot_recon.control import ControlInput
    dt, sub = 0.1, 10
    x, y, yaw = pose
    v = w = 0.0
    costmap = np.zeros(occ.shape, np.uint8)
    poses, outputs = [(x, y, yaw)], []
    for k in range(int(round(seconds / dt))):
        out = controller.compute(ControlInput(
            now_s=k * dt, pose=(x, y, yaw), velocity=(v, w), path=np.asarray(path, float),
            goal_yaw=goal_yaw, occupancy=occ, costmap=costmap, resolution=res, origin=(0.0, 0.0)))
        outputs.append(out)
        if out.status in ("arrived", "blocked", "no_path"):
            break
        for _ in range(sub):
            h = dt / sub
            v += np.clip(out.linear_mps - v, -robot.max_linear_accel_mps2 * h, robot.max_linear_accel_mps2 * h)
            w += np.clip(out.angular_radps - w, -robot.max_angular_accel_radps2 * h,
                         robot.max_angular_accel_radps2 * h)
            x, y, yaw = x + v * math.cos(yaw) * h, y + v * math.sin(yaw) * h, yaw + w * h
            poses.append((x, y, yaw))
    return np.array(poses), outputs


def walled_room(width_cells=80, height_cells=60) -> np.ndarray:
    """int8 occupancy: a walled room, free area [0.05, 0.05 (width - 1)] x [0.05, 0.05 (height - 1)] m."""
    occ = np.zeros((height_cells, width_cells), np.int8)
    occ[0, :] = occ[-1, :] = 100
    occ[:, 0] = occ[:, -1] = 100
    return occ


def corridor_ahead(width_m: float, res: float = 0.01, length_m: float = 3.0) -> np.ndarray:
    """int8 occupancy at ``res`` m per cell, origin (0, 0): a 2 x 1 m walled open area x in
    [0, 0.6) m, y in [0.5, 1.5) m, then a corridor along +x to ``length_m`` of free width
    ``width_m`` centred on y = 1.0 m."""
    n = lambda m: int(round(m / res))
    occ = np.full((n(2.0), n(length_m)), 100, np.int8)
    occ[n(0.5):n(1.5), n(0.05):n(0.6)] = 0
    lo = n(1.0) - n(width_m) // 2
    occ[lo:lo + n(width_m), n(0.05):n(length_m) - 1] = 0
    return occ


def node_pid(name: str, port: int):
    """The pid of node ``name`` of the run whose master is on ``port``, or None."""
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            env = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if f"__name:={name}".encode() in cmd and f"ROS_MASTER_URI=http://127.0.0.1:{port}".encode() in env:
            return int(pid)
    return None
