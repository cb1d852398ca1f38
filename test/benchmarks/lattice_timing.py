#!/usr/bin/env python3
"""Timing of the state-lattice planner (``planning.plan_lattice``), for ``make bench-plan`` and
for comparing two builds of the native module side by side.

- ``reachable_pairs``: n start/goal pairs on a world for a robot, seeded: each start a cell
  centre where the footprint fits at a random lattice heading, each goal at least
  ``MIN_PAIR_DISTANCE_M`` away in a straight line and reached by the lattice from that start
  (``lattice_cost_to_come`` finite there); the planner is then asked for exactly such plans.
- ``time_plans``: each pair planned ``repeats`` times through the Python facade; per pair the
  median, so the figures are the median and p95 over the pairs; on the map as loaded (replans:
  what the planner builds per map is reused) and with the map's bytes changed before each plan.
- ``time_generated``: the 400 x 400 building of bench-map corner to corner (the waffle_pi), and
  a 2,000 x 2,000 one, with the process's peak resident memory after it.

Run as a script it prints one JSON object of these figures; ``--native PATH`` loads that build
of ``turtlebot_recon._native`` instead of the installed one (e.g. main's, copied aside), so two
builds can be timed alternately in one session: the figures of each run go to stdout;
``--compare OLD_SO --rounds N`` runs both builds N times, alternately, and prints the medians
side by side with their ratios.
"""
import argparse
import importlib.util
import json
import math
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def _load_native(path: str) -> None:
    """Make ``path`` the ``turtlebot_recon._native`` every later import gets."""
    spec = importlib.util.spec_from_file_location("turtlebot_recon._native", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["turtlebot_recon._native"] = module
    spec.loader.exec_module(module)


if __name__ == "__main__":
    _parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    _parser.add_argument("--native", help="path of a _native .so to time instead of the installed one")
    _parser.add_argument("--repeats", type=int, default=3, help="plans per pair (median taken)")
    _parser.add_argument("--pairs", type=int, default=30, help="pairs per world and robot")
    _parser.add_argument("--worlds", nargs="+", default=None, help="worlds (names or YAML paths)")
    _parser.add_argument("--no-generated", action="store_true", help="skip the 400^2 / 2000^2 plans")
    _parser.add_argument("--only-2000", action="store_true", help="only the 2000^2 plan (peak memory)")
    _parser.add_argument("--compare", metavar="OLD_SO",
                         help="time that build and the installed one alternately, in fresh processes")
    _parser.add_argument("--rounds", type=int, default=3, help="with --compare: runs of each")
    ARGS = _parser.parse_args()
    if ARGS.native:
        _load_native(ARGS.native)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_map import building_occupancy  # noqa: E402

from turtlebot_recon.planning import LatticeSettings, PlanningError  # noqa: E402
from turtlebot_recon.planning import lattice_cost_to_come, plan_lattice  # noqa: E402
from turtlebot_recon.planning.lattice import footprint_clear  # noqa: E402
from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.robot import load_robot  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402

SHARED_WORLDS = Path(__file__).resolve().parents[3] / "shared" / "worlds"
REAL_MAPS = (str(SHARED_WORLDS / "depot.yaml"), str(SHARED_WORLDS / "tb3_sandbox.yaml"))
ROBOTS = ("turtlebot3_waffle_pi", "turtlebot3_burger")
MIN_PAIR_DISTANCE_M = 2.0     # straight line, start to goal
RES = 0.05                    # m, the generated buildings


def reachable_pairs(world, robot, n: int, seed: int, settings: LatticeSettings) -> list:
    """n (start (x, y, yaw), goal (x, y)) pairs on ``world`` that the lattice connects for
    ``robot``; the same seed, the same pairs."""
    occ, res, origin = world.occupancy(), world.resolution, world.origin
    yaws = np.array([h[2] for h in _native.lattice_headings(settings.headings)])
    free = np.argwhere(occ == 0)
    rng = np.random.default_rng(seed)
    pairs = []
    for _ in range(200 * n):
        if len(pairs) == n:
            break
        r, c = free[rng.integers(len(free))]
        start = (origin[0] + (c + 0.5) * res, origin[1] + (r + 0.5) * res, float(yaws[rng.integers(len(yaws))]))
        if not footprint_clear(occ, res, origin, robot, np.array([start]), settings)[0]:
            continue
        reach = lattice_cost_to_come(occ, res, origin, robot, start, settings, snap_radius_m=0.0)
        goals = np.argwhere(np.isfinite(reach))
        goal_xy = np.column_stack([origin[0] + (goals[:, 1] + 0.5) * res, origin[1] + (goals[:, 0] + 0.5) * res])
        far = goal_xy[np.hypot(goal_xy[:, 0] - start[0], goal_xy[:, 1] - start[1]) >= MIN_PAIR_DISTANCE_M]
        if len(far) == 0:
            continue
        pairs.append((start, tuple(float(v) for v in far[rng.integers(len(far))])))
    if len(pairs) < n:
        raise RuntimeError(f"{world.name}: only {len(pairs)} reachable pairs for {robot.name}")
    return pairs


def time_plans(world, robot, pairs: list, settings: LatticeSettings, repeats: int,
               new_map: bool = False) -> dict:
    """Per pair the median time (ms) of ``repeats`` plans; the median and p95 over the pairs,
    the plans' total cost (a check that two builds find the same paths) and failures.
    ``new_map``: before each plan one corner cell changes between two values on the same side
    of the occupied threshold (100 / 99, or 0 / 1): the same map to plan on, but not the bytes
    the planner last saw, so nothing built for it can be reused (a replan after a map update)."""
    occ, res, origin = world.occupancy(), world.resolution, world.origin
    per_pair, cost_sum, failures = [], 0.0, 0
    for start, goal in pairs:
        times = []
        for _ in range(repeats):
            if new_map:
                occ[0, 0] = {100: 99, 99: 100, 0: 1, 1: 0}[int(occ[0, 0])]
            t0 = time.perf_counter()
            try:
                path = plan_lattice(occ, res, origin, robot, start, goal, settings)
            except PlanningError:
                path = None
            times.append(time.perf_counter() - t0)
        if path is None:
            failures += 1
        else:
            cost_sum += path.cost
        per_pair.append(1e3 * statistics.median(times))
    return {"p50_ms": float(np.percentile(per_pair, 50)), "p95_ms": float(np.percentile(per_pair, 95)),
            "max_ms": max(per_pair), "cost_sum_m": cost_sum, "failures": failures}


def time_worlds(worlds, n_pairs: int, repeats: int, seed: int = 0) -> dict:
    """``time_plans`` on each world for each robot of ROBOTS, keyed ``<world>/<robot>``."""
    out = {}
    for i, name in enumerate(worlds):
        world = load_world(name)
        for j, robot_name in enumerate(ROBOTS):
            robot = load_robot(robot_name)
            settings = LatticeSettings.for_robot(robot)
            pairs = reachable_pairs(world, robot, n_pairs, seed + 100 * i + j, settings)
            out[f"{world.name}/{robot_name}"] = time_plans(world, robot, pairs, settings, repeats)
            out[f"{world.name}/{robot_name}/new_map"] = time_plans(world, robot, pairs, settings,
                                                                  repeats, new_map=True)
    return out


def time_generated(n: int, repeats: int) -> dict:
    """bench-map's building of n x n cells, corner to corner for the waffle_pi: time (median of
    ``repeats``), cost, and the peak resident memory (MB) of the process before and after."""
    robot = load_robot("turtlebot3_waffle_pi")
    occ, settings = building_occupancy(n), LatticeSettings.for_robot(robot)
    start, goal = ((10 + 0.5) * RES, (10 + 0.5) * RES, 0.0), ((n - 11 + 0.5) * RES, (n - 11 + 0.5) * RES)
    times, path = [], None
    base_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        path = plan_lattice(occ, RES, (0.0, 0.0), robot, start, goal, settings)
        times.append(time.perf_counter() - t0)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {f"lattice_ms_{n}": 1e3 * statistics.median(times), f"lattice_cost_m_{n}": path.cost,
            f"lattice_peak_rss_mb_before_{n}": base_mb, f"lattice_peak_rss_mb_after_{n}": peak_mb}


def flat(figures: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in figures.items():
        if isinstance(value, dict):
            out.update(flat(value, f"{prefix}{key}/"))
        else:
            out[prefix + key] = value
    return out


def compare(old_so: str, rounds: int, extra: list) -> None:
    """Runs this script ``rounds`` times with ``old_so`` and with the installed build,
    alternately (the machine's load falls on both alike); prints each figure's median over the
    rounds, old and new side by side, and their ratio."""
    runs = {"old": [], "new": []}
    for _ in range(rounds):
        for which in ("old", "new"):
            cmd = [sys.executable, __file__, *extra] + (["--native", old_so] if which == "old" else [])
            done = subprocess.run(cmd, capture_output=True, text=True, check=True)
            runs[which].append(flat(json.loads(done.stdout.strip().splitlines()[-1])))
    print(f"{'figure':<58} {'old':>10} {'new':>10} {'old/new':>8}")
    for key in sorted(runs["new"][0]):
        old = statistics.median(r[key] for r in runs["old"])
        new = statistics.median(r[key] for r in runs["new"])
        ratio = f"{old / new:8.2f}" if new else ""
        print(f"{key:<58} {old:10.3f} {new:10.3f} {ratio}")


def main() -> None:
    if ARGS.compare:
        extra = [f"--repeats={ARGS.repeats}", f"--pairs={ARGS.pairs}"]
        extra += ["--worlds", *ARGS.worlds] if ARGS.worlds else []
        extra += ["--no-generated"] if ARGS.no_generated else []
        extra += ["--only-2000"] if ARGS.only_2000 else []
        compare(ARGS.compare, ARGS.rounds, extra)
        return
    figures = {}
    if ARGS.only_2000:
        figures.update(time_generated(2000, 1))
    else:
        figures["worlds"] = time_worlds(ARGS.worlds or REAL_MAPS, ARGS.pairs, ARGS.repeats)
        if not ARGS.no_generated:
            figures.update(time_generated(400, 11))
    print(json.dumps(figures, sort_keys=True))


if __name__ == "__main__":
    main()
