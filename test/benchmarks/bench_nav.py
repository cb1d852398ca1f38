#!/usr/bin/env python3
"""Point-to-point navigation benchmark (`make bench-nav`, issue 18 item 7): every controller
over the same start/goal pairs in house, office and maze, in the simulator, outside ROS.

Each run is the navigator's core (``planning.navigation.Navigation``: the state-lattice plan,
replanning, the selected controller, every parameter at its config/ default) driving the
PyBullet simulator (``sim.Simulator``, the one sim_bridge wraps) in one process, closed at the
navigator's own rate (controller_rate_hz, sim time). The map is the world's own grid, as a map
made once and loaded (mode:=localization) would be. The pose the controller gets:

- ``--pose localization`` (default): odometry drifting at bench-slam's default (wheel slip
  0.01 per sqrt(m), heading from the wheels), corrected by the localiser
  (``slam.localization.Localizer``: scan-to-map EKF, as the slam node runs it in
  mode:=localization) from the lidar the simulator renders; the robot starts where the
  localiser is told it is (an rviz 2D Pose Estimate);
- ``--pose truth``: the simulator's true pose (no estimation error: the controllers alone).

The start/goal pairs are fixed: test/benchmarks/nav_pairs.yaml, made once by ``--make-pairs``
(seeded; each start where the robot fits at any heading with 0.1 m to spare, each goal at least
2 m away in a straight line and reachable by the lattice planner from the start pose). The
maze is driven by the burger (its corridors), house and office by the waffle_pi.

Per run: success (the navigator says succeeded and the true position is within its goal
tolerance + 0.1 m), time to goal (sim s), path ratio (the true distance driven over the length
of the lattice plan from the start pose on the true map: "the A* length"), speed ratio (mean
true |v| while translating, |v| >= 0.02 m/s, over the robot's max_linear_mps), minimum clearance
(the oriented body to the nearest wall cell, ``_native.body_field_clearance`` at the true pose
every control period), collisions (the simulator's contact count), mean |jerk| of the commanded
v and w (second difference over the control period squared, as bench-control), stops (the
commanded v dropping below 0.01 m/s after it was above 0.05, the final stop not counted) and
reversals (the commanded v changing sign). Runs go in parallel (--jobs, default the cores);
each finished run is appended to output/bench/nav_runs.jsonl (--resume reuses those whose
settings match).

Output: output/bench/nav.json: per controller over all worlds ``nav_<figure>_<controller>``
(success_rate, time_s over its successful trips, time_common_s over the pairs every
controller reached, path_ratio, speed_ratio, avg_speed_ratio = the whole trip's mean speed
over the maximum, clearance_min_m, collisions, jerk, angular_jerk, stops, reversals,
step_ms_p95, and the failures with their reasons), per world under ``worlds``, the pick
(``nav_pick``: no collision first, then the highest success rate, then the shortest
time_common_s), and the tables printed; the default controller (config/navigator.yaml) is set
from it by hand and README says why.
"""
import argparse
import dataclasses
import json
import math
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_control import jerk  # noqa: E402
from common import TOP, write  # noqa: E402

from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.control import CONTROLLERS  # noqa: E402
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH  # noqa: E402
from turtlebot_recon.planning.costmap import PlanningError  # noqa: E402
from turtlebot_recon.planning.lattice import LatticeSettings, plan_lattice  # noqa: E402
from turtlebot_recon.planning.navigation import Navigation, NavigationSettings  # noqa: E402
from turtlebot_recon.robot import footprint_args, load_robot  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402
from turtlebot_recon.sim.simulator import SimSettings, Simulator  # noqa: E402
from turtlebot_recon.slam.localization import Localizer, LocalizationSettings  # noqa: E402
from turtlebot_recon.slam.scan_matching import scan_points  # noqa: E402
from turtlebot_recon.geometry import compose  # noqa: E402

PAIRS_FILE = TOP / "test" / "benchmarks" / "nav_pairs.yaml"
RUNS_FILE = TOP / "output" / "bench" / "nav_runs.jsonl"
WORLD_ROBOTS = {"house": "turtlebot3_waffle_pi", "office": "turtlebot3_waffle_pi", "maze": "turtlebot3_burger"}
PAIRS_PER_WORLD = 30
MIN_PAIR_DISTANCE_M = 2.0     # straight line, start to goal
START_SPARE_M = 0.1           # start clearance beyond the footprint's circumscribed radius
DEFAULT_SLIP = 0.01           # bench-slam's "default" drift level (per sqrt(m))
SUCCESS_SLACK_M = 0.1         # true distance to goal allowed beyond the goal tolerance
DRIVING_MPS = 0.02            # |v| at least this: translating (speed ratio)
STOP_MPS, MOVING_MPS = 0.01, 0.05


def circumscribed_m(robot) -> float:
    if robot.is_round:
        return robot.radius_m
    hx, hy = 0.5 * robot.footprint_length_m, 0.5 * robot.footprint_width_m
    return math.hypot(abs(robot.footprint_offset_x_m) + hx, hy)


# ---------------------------------------------------------------------- the fixed pairs
def make_pairs(world_name: str, robot_name: str, n: int, seed: int) -> list:
    world, robot = load_world(world_name), load_robot(robot_name)
    occ = world.occupancy()
    lattice = LatticeSettings()
    ok = np.argwhere(world.clearance() >= circumscribed_m(robot) + START_SPARE_M)
    centres = np.column_stack([world.origin[0] + (ok[:, 1] + 0.5) * world.resolution,
                               world.origin[1] + (ok[:, 0] + 0.5) * world.resolution])
    rng = np.random.default_rng(seed)
    pairs, tries = [], 0
    while len(pairs) < n:
        tries += 1
        if tries > 200 * n:
            raise RuntimeError(f"{world_name}: only {len(pairs)} pairs in {tries} tries")
        a, b = centres[rng.integers(len(centres))], centres[rng.integers(len(centres))]
        if math.hypot(*(b - a)) < MIN_PAIR_DISTANCE_M:
            continue
        start = (float(a[0]), float(a[1]), float(rng.uniform(-math.pi, math.pi)))
        try:
            plan = plan_lattice(occ, world.resolution, world.origin, robot, start, b, lattice)
        except PlanningError:
            continue
        pairs.append(dict(start=[round(v, 3) for v in start], goal=[round(float(v), 3) for v in b],
                          plan_m=round(float(plan.length_m), 3)))
    return pairs


def write_pairs(seed: int) -> None:
    doc = {"seed": seed, "worlds": {}}
    for i, (w, r) in enumerate(WORLD_ROBOTS.items()):
        doc["worlds"][w] = {"robot": r, "pairs": make_pairs(w, r, PAIRS_PER_WORLD, seed + i)}
        print(f"{w}: {PAIRS_PER_WORLD} pairs, plan lengths "
              f"{min(p['plan_m'] for p in doc['worlds'][w]['pairs']):.1f}-"
              f"{max(p['plan_m'] for p in doc['worlds'][w]['pairs']):.1f} m")
    header = ("# bench-nav's fixed start/goal pairs (test/benchmarks/bench_nav.py --make-pairs; do not edit\n"
              "# by hand). start: (x m, y m, yaw rad) in the world frame; goal: (x, y), any heading;\n"
              "# plan_m: the lattice plan's length from the start pose on the true map.\n")
    PAIRS_FILE.write_text(header + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))


# ---------------------------------------------------------------------- one run
def command_stats(commands: np.ndarray, dt: float) -> dict:
    v = commands[:, 0] if len(commands) else np.zeros(0)
    j = jerk(commands, dt)
    stops, moving = 0, False
    for x in np.abs(v):
        if x > MOVING_MPS:
            moving = True
        elif x < STOP_MPS and moving:
            stops, moving = stops + 1, False
    if len(v) and abs(v[-1]) < STOP_MPS and stops:      # the arrival is not a stop
        stops -= 1
    signs = np.sign(v[np.abs(v) >= STOP_MPS])
    return dict(jerk=float(j[0]), angular_jerk=float(j[1]), stops=int(stops),
                reversals=int(np.count_nonzero(signs[1:] != signs[:-1])))


def run_one(task: dict) -> dict:
    world = load_world(task["world"])
    world = dataclasses.replace(world, start=tuple(task["start"]))
    robot = load_robot(task["robot"])
    slip = DEFAULT_SLIP if task["pose"] == "localization" else 0.0
    sim = Simulator(world, robot, SimSettings(world=task["world"], robot=task["robot"], rtf=0.0, camera_rate_hz=0.0,
                                              odom_slip_std_sqrt_m=slip, seed=task["index"]))
    occ = world.occupancy()
    settings = NavigationSettings(robot=task["robot"], controller=task["controller"])
    nav = Navigation(settings, robot)
    nav.update_map(occ, world.resolution, world.origin)
    goal = tuple(task["goal"])
    nav.set_goal(goal[0], goal[1])
    loc = None
    if task["pose"] == "localization":
        loc = Localizer(LocalizationSettings(), occ, world.resolution, world.origin, robot.wheel_separation_m)
        loc.set_pose(world.start)
    lid = robot.lidar
    per = max(1, round(1.0 / (settings.controller_rate_hz * sim.dt)))
    dt = per * sim.dt
    limit_s = 20.0 + 4.0 * task["plan_m"] / robot.max_linear_mps
    start = np.array(world.start)
    commands, truth, speeds, step_ms = [], [], [], []
    k = 0
    try:
        while nav.status == "active" and sim.time_s < limit_s:
            o = sim.odom
            odom = (o.x, o.y, o.yaw)
            if k % per == 0:
                if loc is None:
                    pose = tuple(sim.pose)
                else:
                    pose = tuple(compose(loc.map_to_odom(), np.array(odom))) if loc.odom is not None \
                        else tuple(compose(start, np.array(odom)))
                t0 = time.perf_counter()
                v, w = nav.step(sim.time_s, pose, (o.v, o.w))
                step_ms.append(1e3 * (time.perf_counter() - t0))
                if not (math.isfinite(v) and math.isfinite(w)):
                    raise ValueError(f"non-finite command ({v}, {w})")
                sim.set_command(v, w)
                commands.append((v, w))
                truth.append(sim.pose.copy())
                speeds.append(sim.twist[0])
            due = sim.step()
            k += 1
            if loc is not None and "scan" in due:
                ranges = sim.scan()
                pts = scan_points(ranges, lid.angle_min_rad, lid.angle_increment_rad, lid.range_min_m, lid.range_max_m)
                loc.add_scan(sim.time_s, pts + np.array([lid.x_m, lid.y_m]), (sim.odom.x, sim.odom.y, sim.odom.yaw))
        x, y, _ = sim.pose
        off = math.hypot(x - goal[0], y - goal[1])
        tol = settings.tracking.xy_goal_tolerance_m
        success = nav.status == "succeeded" and off <= tol + SUCCESS_SLACK_M
        truth_a = np.array(truth).reshape(-1, 3)
        clearance = _native.body_field_clearance(
            occ, world.resolution, (world.origin[0], world.origin[1]), truth_a,
            spacing_m=0.02, max_m=1.0, **footprint_args(robot), occupied_threshold=OCCUPIED_THRESH)
        sp = np.abs(np.array(speeds))
        driving = sp[sp >= DRIVING_MPS]
        out = dict(task, success=bool(success), status=nav.status, reason=nav.reason, off_goal_m=round(off, 3),
                   time_s=round(sim.time_s, 2), driven_m=round(float(sim.distance_m), 3),
                   path_ratio=round(float(sim.distance_m) / max(task["plan_m"], 1e-6), 4),
                   speed_ratio=round(float(driving.mean()) / robot.max_linear_mps, 4) if len(driving) else 0.0,
                   clearance_min_m=round(float(clearance.min()), 4) if len(clearance) else None,
                   collisions=int(sim.collisions), takeovers=nav.takeovers, step_ms_mean=round(float(np.mean(step_ms)), 3),
                   step_ms_p95=round(float(np.percentile(step_ms, 95)), 3),
                   **command_stats(np.array(commands).reshape(-1, 2), dt))
        if loc is not None:
            est = compose(loc.map_to_odom(), np.array((sim.odom.x, sim.odom.y, sim.odom.yaw)))
            out["loc_error_m"] = round(math.hypot(est[0] - x, est[1] - y), 4)
            out["loc_fused"] = loc.stats().get("fused", 0)
        return out
    except Exception as exc:     # a crash is a failed run with its reason, never a lost one
        return dict(task, success=False, status="error", reason=f"{type(exc).__name__}: {exc}", collisions=0,
                    time_s=round(sim.time_s, 2))
    finally:
        sim.close()


# ---------------------------------------------------------------------- aggregation
FIGURES = ("success_rate", "time_s", "time_common_s", "path_ratio", "speed_ratio", "avg_speed_ratio",
           "clearance_min_m", "collisions", "jerk", "angular_jerk", "stops", "reversals", "takeovers", "step_ms_p95")


def summarise(runs: list, common: set) -> dict:
    """One controller's runs. ``common``: the (world, index) pairs every controller reached,
    over which ``time_common_s`` compares times on equal terms (a controller failing the hard
    pairs would otherwise look fast)."""
    ok = [r for r in runs if r["success"]]

    def mean(key, rows):
        vals = [r[key] for r in rows if r.get(key) is not None]
        return round(float(np.mean(vals)), 4) if vals else None
    clear = [r["clearance_min_m"] for r in runs if r.get("clearance_min_m") is not None]
    # the mean speed over the whole trip (turns in place and stops included) over the maximum
    avg_speed = [r["driven_m"] / max(r["time_s"], 1e-6) / load_robot(r["robot"]).max_linear_mps for r in ok]
    return dict(runs=len(runs), success_rate=round(len(ok) / max(len(runs), 1), 4),
                time_s=mean("time_s", ok),
                time_common_s=mean("time_s", [r for r in ok if (r["world"], r["index"]) in common]),
                path_ratio=mean("path_ratio", ok), speed_ratio=mean("speed_ratio", runs),
                avg_speed_ratio=round(float(np.mean(avg_speed)), 4) if avg_speed else None,
                clearance_min_m=round(min(clear), 4) if clear else None,
                collisions=int(sum(r.get("collisions", 0) for r in runs)), jerk=mean("jerk", runs),
                angular_jerk=mean("angular_jerk", runs), stops=mean("stops", runs), reversals=mean("reversals", runs),
                # the pure pursuit's takeovers where the controller was blocked (navigator.takeover_m)
                takeovers=round(float(np.mean([r.get("takeovers", 0) for r in runs])), 4) if runs else None,
                step_ms_p95=mean("step_ms_p95", runs),
                failures=[f"{r['world']}#{r['index']}: {r['status']} {r.get('reason', '')}"[:160]
                          for r in runs if not r["success"]])


def pick(per_controller: dict) -> str:
    """No collision first, then the highest success rate, then the shortest mean time to goal
    over the pairs every controller reached."""
    return min(per_controller, key=lambda c: (per_controller[c]["collisions"] > 0,
                                              -per_controller[c]["success_rate"],
                                              per_controller[c]["time_common_s"] or math.inf))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--controllers", default=",".join(CONTROLLERS))
    ap.add_argument("--worlds", default=",".join(WORLD_ROBOTS))
    ap.add_argument("--pairs", type=int, default=PAIRS_PER_WORLD, help="the first N pairs of each world")
    ap.add_argument("--pose", choices=("localization", "truth"), default="localization")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--make-pairs", action="store_true", help="write test/benchmarks/nav_pairs.yaml and stop")
    ap.add_argument("--seed", type=int, default=18)
    args = ap.parse_args()
    if args.make_pairs:
        write_pairs(args.seed)
        return 0
    controllers = [c for c in args.controllers.split(",") if c]
    unknown = [c for c in controllers if c not in CONTROLLERS]
    if unknown:
        print(f"bench-nav: unknown controller(s) {', '.join(unknown)}; choose from {', '.join(CONTROLLERS)}")
        return 2
    doc = yaml.safe_load(PAIRS_FILE.read_text())
    worlds = [w for w in args.worlds.split(",") if w]
    tasks = []
    for w in worlds:
        if w not in doc["worlds"]:
            print(f"bench-nav: no pairs for world '{w}' in {PAIRS_FILE}")
            return 2
        entry = doc["worlds"][w]
        for c in controllers:
            for i, p in enumerate(entry["pairs"][:args.pairs]):
                tasks.append(dict(world=w, robot=entry["robot"], controller=c, index=i, pose=args.pose,
                                  start=p["start"], goal=p["goal"], plan_m=p["plan_m"]))
    key = lambda t: (t["world"], t["robot"], t["controller"], t["index"], t["pose"], tuple(t["start"]), tuple(t["goal"]))
    done = {}
    RUNS_FILE.parent.mkdir(parents=True, exist_ok=True)
    if args.resume and RUNS_FILE.exists():
        for line in RUNS_FILE.read_text().splitlines():
            r = json.loads(line)
            done[key(r)] = r
    else:
        RUNS_FILE.write_text("")
    todo = [t for t in tasks if key(t) not in done]
    print(f"bench-nav: {len(tasks)} runs ({len(worlds)} worlds x {len(controllers)} controllers x "
          f"{args.pairs} pairs, pose {args.pose}), {len(todo)} to run on {args.jobs} jobs", flush=True)
    t0 = time.monotonic()
    with mp.get_context("fork").Pool(args.jobs) as pool, RUNS_FILE.open("a") as log:
        for n, r in enumerate(pool.imap_unordered(run_one, todo), 1):
            done[key(r)] = r
            log.write(json.dumps(r) + "\n")
            log.flush()
            if not r["success"] or n % 25 == 0:
                print(f"  [{n}/{len(todo)} {time.monotonic() - t0:.0f} s] {r['world']} {r['controller']} #{r['index']}: "
                      f"{'ok' if r['success'] else 'FAIL ' + r['status'] + ' ' + r.get('reason', '')[:100]}", flush=True)
    runs = [done[key(t)] for t in tasks]
    figures, per_world = {}, {}
    reached = {}
    for r in runs:
        reached.setdefault((r["world"], r["index"]), set()).add(r["controller"] if r["success"] else None)
    common = {k for k, cs in reached.items() if None not in cs}
    per_controller = {c: summarise([r for r in runs if r["controller"] == c], common) for c in controllers}
    for w in worlds:
        per_world[w] = {c: summarise([r for r in runs if r["controller"] == c and r["world"] == w], common)
                        for c in controllers}
    for c, s in per_controller.items():
        for f in FIGURES:
            figures[f"nav_{f}_{c}"] = s[f]
        figures[f"nav_failures_{c}"] = s["failures"]
    figures["nav_pick"] = pick(per_controller)
    figures["nav_common_pairs"] = len(common)
    figures["worlds"] = {w: {c: {k: v for k, v in s.items() if k != "failures"} for c, s in d.items()}
                         for w, d in per_world.items()}
    figures["pose"] = args.pose
    figures["pairs_per_world"] = args.pairs
    figures["wall_s"] = round(time.monotonic() - t0, 1)
    head = ("controller", "success", "time_s", "common_s", "path", "speed", "avg_spd", "clear_m", "coll", "jerk",
            "stops", "rev", "takeov", "p95_ms")
    for w, d in [*per_world.items(), ("all worlds", per_controller)]:
        print(f"\n{w}\n{head[0]:<14}" + "".join(f"{h:>9}" for h in head[1:]))
        for c, s in d.items():
            vals = [s[k] for k in ("success_rate", "time_s", "time_common_s", "path_ratio", "speed_ratio",
                                   "avg_speed_ratio", "clearance_min_m", "collisions", "jerk", "stops", "reversals",
                                   "takeovers", "step_ms_p95")]
            print(f"{c:<14}" + "".join(f"{v:>9.3f}" if isinstance(v, float) else f"{v!s:>9}" for v in vals))
    write("nav", figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
