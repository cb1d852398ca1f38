#!/usr/bin/env python3
"""Mapping and planning core benchmark (`make bench-map`), each compared in the same run.

1. Scan insertion: 360-beam, 3.5 m scans (taken by the simulator in the house) into a 0.05 m
   grid, C++ ``OccupancyGrid.insert_scan`` against a vectorised numpy version of the same
   log-odds update. Target >= 5,000 scans/s.
2. A* corner to corner on 400 x 400 and 2,000 x 2,000 costmaps, inflated for the burger: a
   building of 4 m rooms joined by 1 m doors (the headline figures) and a stress case of
   random rectangles (``_random``), C++ against a plain-Python heapq A* with the same cost
   model on the 400 x 400 maps. Targets: <= 5 ms on 400 x 400, >= 50x Python.
3. Exact Euclidean distance transform of a 2,000 x 2,000 grid, C++ (Felzenszwalb-Huttenlocher)
   against scipy.ndimage.distance_transform_edt.
4. State-lattice A* (16 headings, the waffle_pi's oriented box) corner to corner on the 400 x 400
   building of 2., from the occupancy grid (its distance field and graded costs included), and
   its ratio to the 2-D A* of 2. in the same run.
Setup happens outside the timed sections; each figure is the median of several repeats.
"""
import heapq
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write  # noqa: E402

from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.mapping import GridSettings, make_grid  # noqa: E402
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH  # noqa: E402
from turtlebot_recon.planning import LatticeSettings, PlannerSettings, plan_lattice  # noqa: E402
from turtlebot_recon.planning.costmap import cost_model  # noqa: E402
from turtlebot_recon.robot import load_robot  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402
from turtlebot_recon.sim.simulator import SimSettings, Simulator  # noqa: E402

RES = 0.05
COST = cost_model(PlannerSettings(), RES)     # the planner's step cost (the bindings take every argument)
L_HIT, L_MISS = math.log(0.7 / 0.3), math.log(0.4 / 0.6)
L_MIN, L_MAX = math.log(0.12 / 0.88), math.log(0.97 / 0.03)


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def house_scans(n: int):
    """(pose, ranges) pairs from the simulator: realistic 360-beam scans at random free poses."""
    world = load_world("house")
    sim = Simulator(world, load_robot("turtlebot3_burger"), SimSettings(camera_rate_hz=0.0))
    rng = np.random.default_rng(0)
    clear = world.clearance() > 0.3
    rows, cols = np.nonzero(clear)
    out = []
    while len(out) < n:
        k = rng.integers(len(rows))
        x = world.origin[0] + (cols[k] + 0.5) * world.resolution
        y = world.origin[1] + (rows[k] + 0.5) * world.resolution
        sim.set_pose(x, y, rng.uniform(-math.pi, math.pi))
        out.append(((x, y, sim.pose[2]), sim.scan()))
    sim.close()
    return out, sim.robot.lidar


def numpy_insert(logodds, origin, pose, ranges, lid):
    """The same update, vectorised: sample every beam at half-cell steps; each cell of the scan
    gets one update, a hit if any beam ends there, else one miss (OctoMap's rule, as in C++)."""
    a = pose[2] + lid.angle_min_rad + lid.angle_increment_rad * np.arange(ranges.size)
    ok = np.isfinite(ranges) & (ranges >= lid.range_min_m) & (ranges <= lid.range_max_m)
    r, a = ranges[ok], a[ok]
    t = np.arange(0.0, lid.range_max_m, 0.5 * RES)[None, :] * np.ones((r.size, 1))
    inside = t < (r[:, None] - 0.5 * RES)
    rows = ((pose[1] + t * np.sin(a)[:, None] - origin[1]) / RES).astype(int)
    cols = ((pose[0] + t * np.cos(a)[:, None] - origin[0]) / RES).astype(int)
    crossed = np.unique(rows[inside] * logodds.shape[1] + cols[inside])
    hr = ((pose[1] + r * np.sin(a) - origin[1]) / RES).astype(int)
    hc = ((pose[0] + r * np.cos(a) - origin[0]) / RES).astype(int)
    hits = np.unique(hr * logodds.shape[1] + hc)
    flat = logodds.reshape(-1)
    flat[np.setdiff1d(crossed, hits, assume_unique=True)] += L_MISS
    flat[hits] += L_HIT
    np.clip(flat, L_MIN, L_MAX, out=flat)


def bench_scans() -> dict:
    scans, lid = house_scans(200)
    grid = make_grid(GridSettings(resolution=RES, width_m=20.0, height_m=15.0, origin_x=-2.0, origin_y=-2.0))

    def native():
        for pose, r in scans:
            grid.insert_scan(pose[0], pose[1], pose[2], r, lid.angle_min_rad, lid.angle_increment_rad,
                             lid.range_min_m, lid.range_max_m, no_return_clear_m=0.0, range_cap_m=0.0)

    logodds = np.zeros((300, 400))

    def vectorised():
        for pose, r in scans[:50]:
            numpy_insert(logodds, (-2.0, -2.0), pose, r, lid)

    native()   # warm up (and grow nothing: the grid already covers the house)
    per_s = len(scans) / median_time(native, 7)
    per_s_numpy = 50 / median_time(vectorised, 3)
    return {"scan_inserts_per_s": per_s, "scan_inserts_numpy_per_s": per_s_numpy,
            "scan_inserts_ratio_vs_numpy": per_s / per_s_numpy}


def inflated(occ: np.ndarray) -> np.ndarray:
    """The burger's costmap: inscribed 0.1 m, inflation 0.4 m, decay 5 / m (Nav2 convention)."""
    return _native.inflate(occ, RES, 0.1, 0.4, 5.0, occupied_threshold=OCCUPIED_THRESH, unknown_is_obstacle=False)


def building_occupancy(n: int, room: int = 80, wall: int = 2, door: int = 20,
                       seed: int = 3) -> np.ndarray:
    """A building (int8 occupancy): 4 m square rooms (walls 0.1 m) with a 1 m door in two walls
    each and two pieces of furniture per room; a corner-to-corner plan crosses n / room rooms
    each way."""
    rng = np.random.default_rng(seed)
    occ = np.zeros((n, n), np.int8)
    for k in range(0, n, room):
        occ[k:k + wall, :] = 100
        occ[:, k:k + wall] = 100
    for r0 in range(0, n, room):
        for c0 in range(0, n, room):
            d = rng.integers(wall + 5, room - door - 5)
            occ[r0:r0 + wall, c0 + d:c0 + d + door] = 0
            d = rng.integers(wall + 5, room - door - 5)
            occ[r0 + d:r0 + d + door, c0:c0 + wall] = 0
            for _ in range(2):
                h, w = rng.integers(6, 20, 2)
                r = r0 + rng.integers(wall + 12, room - h - 12)
                c = c0 + rng.integers(wall + 12, room - w - 12)
                occ[r:r + h, c:c + w] = 100
    occ[:wall, :] = occ[-wall:, :] = 100
    occ[:, :wall] = occ[:, -wall:] = 100
    return occ


def building_costmap(n: int) -> np.ndarray:
    return inflated(building_occupancy(n))


def random_costmap(n: int, seed: int = 1) -> np.ndarray:
    """A stress case: random rectangles over ~20 % of the area, a maze of narrow gaps where
    almost every free cell carries inflation cost and A* expands most of the map."""
    rng = np.random.default_rng(seed)
    occ = np.zeros((n, n), np.int8)
    while (occ == 100).mean() < 0.2:
        h, w = rng.integers(2, max(3, n // 20), 2)
        r, c = rng.integers(0, n - h), rng.integers(0, n - w)
        occ[r:r + h, c:c + w] = 100
    occ[:n // 20, :n // 20] = 0           # keep the corners free for start and goal
    occ[-(n // 20):, -(n // 20):] = 0
    return inflated(occ)


def python_astar(cost: np.ndarray, start, goal) -> float:
    """Textbook A* in plain Python: the same 8-connected cost model as the C++ one."""
    rows, cols = cost.shape
    c = cost.tolist()
    g = {start: 0.0}
    heap = [(0.0, start)]
    closed = set()
    sq2 = math.sqrt(2.0)

    def h(p):
        dr, dc = abs(p[0] - goal[0]), abs(p[1] - goal[1])
        return RES * (max(dr, dc) + (sq2 - 1.0) * min(dr, dc))

    while heap:
        _, p = heapq.heappop(heap)
        if p == goal:
            return g[p]
        if p in closed:
            continue
        closed.add(p)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if dr == 0 and dc == 0:
                    continue
                q = (p[0] + dr, p[1] + dc)
                if not (0 <= q[0] < rows and 0 <= q[1] < cols) or c[q[0]][q[1]] >= 253:
                    continue
                if dr and dc and (c[p[0] + dr][p[1]] >= 253 or c[p[0]][p[1] + dc] >= 253):
                    continue
                ng = g[p] + RES * (sq2 if dr and dc else 1.0) * (1.0 + c[q[0]][q[1]] / 252.0)
                if ng < g.get(q, math.inf):
                    g[q] = ng
                    heapq.heappush(heap, (ng + h(q), q))
    return math.inf


def bench_astar() -> dict:
    out = {}
    for name, make in (("", building_costmap), ("_random", random_costmap)):
        for n, repeats in ((400, 21), (2000, 5)):
            cost = make(n)
            start, goal = (10, 10), (n - 11, n - 11)
            path, total = _native.astar(cost, start, goal, **COST)
            assert len(path) and math.isfinite(total)
            out[f"astar_ms_{n}{name}"] = 1e3 * median_time(lambda: _native.astar(cost, start, goal, **COST), repeats)
            if n == 400:
                t0 = time.perf_counter()
                py_total = python_astar(cost, start, goal)
                py_ms = 1e3 * (time.perf_counter() - t0)
                assert abs(py_total - total) < 1e-6 * total, (py_total, total)   # the same optimum
                out[f"astar_python_ms_400{name}"] = py_ms
                out[f"astar_ratio_vs_python{name}"] = py_ms / out[f"astar_ms_400{name}"]
    return out


def bench_lattice(astar_ms_400: float) -> dict:
    """The lattice plan across the 400 x 400 building, start and goal of bench_astar's plan,
    the robot facing east at the start."""
    robot = load_robot("turtlebot3_waffle_pi")
    occ, settings = building_occupancy(400), LatticeSettings.for_robot(robot)
    start, goal = ((10 + 0.5) * RES, (10 + 0.5) * RES, 0.0), ((389 + 0.5) * RES, (389 + 0.5) * RES)
    path = plan_lattice(occ, RES, (0.0, 0.0), robot, start, goal, settings)
    assert tuple(path.cells[-1]) == (389, 389)
    ms = 1e3 * median_time(lambda: plan_lattice(occ, RES, (0.0, 0.0), robot, start, goal, settings), 11)
    return {"lattice_ms_400": ms, "lattice_ratio_vs_astar": ms / astar_ms_400,
            "lattice_path_m_400": path.length_m, "lattice_turned_rad_400": path.turned_rad}


def bench_edt() -> dict:
    rng = np.random.default_rng(2)
    mask = (rng.random((2000, 2000)) < 0.01).astype(np.uint8)
    d = _native.distance_transform(mask, RES)
    ref = ndimage.distance_transform_edt(mask == 0) * RES
    assert np.allclose(d, ref, atol=1e-4)
    ms = 1e3 * median_time(lambda: _native.distance_transform(mask, RES), 5)
    ms_scipy = 1e3 * median_time(lambda: ndimage.distance_transform_edt(mask == 0), 3)
    return {"edt_ms_2000": ms, "edt_scipy_ms_2000": ms_scipy, "edt_ratio_vs_scipy": ms_scipy / ms}


def main():
    figures = {}
    figures.update(bench_scans())
    figures.update(bench_astar())
    figures.update(bench_lattice(figures["astar_ms_400"]))
    figures.update(bench_edt())
    write("map", figures)


if __name__ == "__main__":
    main()
