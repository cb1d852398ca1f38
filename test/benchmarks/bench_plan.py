#!/usr/bin/env python3
"""Global planner benchmark (`make bench-plan`, issue 33 item 5): every planner over the same
random start/goal pairs, on every shipped world and the two real maps, for both footprints.

Worlds: every world in worlds/ and ../shared/worlds/{depot,tb3_sandbox}.yaml, as their true
grids. Robots: the waffle_pi (its 0.281 x 0.306 m box) and the burger (its 0.105 m disc).
Pairs (``sample_pairs``, fixed seed): 30 per world and robot; the start a lattice pose (a
free cell's centre, one of the 16 lattice headings) where the footprint keeps the lattice's
margin + 1 mm; the goal a free cell's centre at least 1 m away that the state lattice reaches
from the start (``lattice_cost_to_come``) and where the footprint keeps as much at the heading
the reference plan arrives with; given to every planner as (x, y): any heading, as the
navigator's goals.

Planners, each called from the occupancy grid as a caller with a fresh map would (the time
includes what it builds from the grid: distance fields, costmaps):
- ``lattice``: ``plan_lattice`` with config/lattice.yaml (the navigator's planner);
- ``astar_shortcut``: ``costmap.plan`` (A*) on the lattice's own ``footprint_costmap``, where a
  cell is passable when some lattice heading of the body fits (for the disc: where the disc
  fits; the turning-disc costmap would shut the box out of the gaps it drives through
  sideways-on, which the pairs include), then the shortcut for the footprint
  (``planning.sampling.shortcut_turn_drive``: from each kept pose the farthest later cell the
  body reaches by a turn in place and a straight drive, the lattice's margins; a line-of-sight
  shortcut over the costmap cut the box's corners and turned it where it does not fit:
  0.70 of the waffle_pi's paths collided at 82dc6d0);
- ``rrt_seed003``: seed 003's RRT (``planning.rrt_seed003``) with its own step and node limits,
  RNG seeded with the pair's index;
- ``ompl_<planner>_<tier>``: ``planning.sampling.plan_sampling`` for each of OMPL_PLANNERS at
  two budgets, tier ``0_05s`` (0.05 s) and tier ``0_2s`` (0.2 s; 1 s on the real maps), with
  config/lattice.yaml's margins and turn cost, the goal at any heading as the lattice's. OMPL
  draws from its own process-wide generator (plan_sampling takes no seed): its figures vary a
  little from run to run.

Figures per planner, over all pairs: success rate (a path returned AND the footprint clear along
it: the path driven turn-drive-turn as the navigator's follower drives it (backward where the
planner says so), ``densify``, poses
every <= resolution / 2 of travel and of the body's farthest point's arc when turning in place,
``_native.footprint_clearance`` > 0, i.e. margin 0; a 2-D path faces along each segment and
turns in place at its vertices), found rate (a path returned), the failures by reason
(``failure_reason``), time median and p95 (ms, every call), length ratio (mean over successes of
the path's driven length over the reference's) and minimum clearance (m, the least over its
successful paths, capped at 0.5 m). The reference is the lattice's shortest driven path for the
same footprint: plan_lattice with cost_weight 0, turns free and backward moves at the forward
cost, so its cost is its driven length (16 headings: an any-angle path can be up to ~3 % shorter).

Output: output/bench/plan.json: ``<figure>_<planner>`` keys, the issue's headline keys
``min_success_rate`` (over lattice, astar_shortcut and every OMPL planner at tier 0_2s; seed
003's RRT and tier 0_05s apart), ``best_ompl_length_ratio_0_2s``, ``astar_shortcut_length_ratio``,
``lattice_p95_ms_real_maps``; per world and per robot under ``worlds`` and ``robots``; the
OctoMap layer's ``octomap_*`` figures (octomap_figures.py: ``octomap_insert_ms`` per 160 x 120
depth frame, ``octomap_mb_per_100m2``); the 3-D check's (explore_3d.py, after the planners:
``collisions_octomap_on`` / ``_off``, ``coverage_octomap_on`` / ``_off``: a TurtleBot 2 explores
the house with low furniture with the OctoMap layer on and off, two launches side by side);
every call in output/bench/plan_runs.jsonl. Runs one planner call at a time (the budgets are
wall time).
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import REAL_MAPS, SHARED_WORLDS, TOP, write  # noqa: E402
from explore_3d import explore_3d  # noqa: E402
from octomap_figures import octomap_figures  # noqa: E402

from turtlebot_recon import _native, geometry  # noqa: E402
from turtlebot_recon.config import from_dict, load_yaml  # noqa: E402
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH  # noqa: E402
from turtlebot_recon.paths import SHARE_DIR  # noqa: E402
from turtlebot_recon.planning import (LatticeSettings, PlannerSettings, PlanningError, footprint_clear,  # noqa: E402
                                      footprint_costmap, lattice_cost_to_come, plan, plan_lattice,
                                      plan_rrt_seed003)
from turtlebot_recon.robot import footprint_args, load_robot  # noqa: E402
from turtlebot_recon.sim import WorldError, load_world  # noqa: E402

from turtlebot_recon.planning.sampling import OMPL_PLANNERS, plan_sampling, shortcut_turn_drive  # noqa: E402

ROBOTS = ("turtlebot3_waffle_pi", "turtlebot3_burger")
PAIRS_PER_WORLD = 30
SEED = 33
MIN_PAIR_DISTANCE_M = 1.0          # straight line, start to goal
SPARE_M = 0.001                    # start and goal poses keep the lattice's margin + this: none
                                   # exactly on it, where the planners' float checks disagree (OMPL's
                                   # refused the burger 0.125 m from a wall, clearance 0.02 = margin)
TIERS = {"0_05s": (0.05, 0.05), "0_2s": (0.2, 1.0)}   # OMPL budget (s): shipped worlds, real maps
CLEARANCE_CAP_M = 0.5              # clearance is measured out to this far
BASE_PLANNERS = ("lattice", "astar_shortcut", "rrt_seed003")
RUNS_FILE = TOP / "output" / "bench" / "plan_runs.jsonl"
# Estimated wall seconds per call, for the printed estimate (the sweep of bbafb8c: 22 min against
# 21 estimated): the lattice, A*, the RRT, a pair's drawing; OMPL's anytime planners spend their
# budget and as much again as ~7 % simplifying, RRT-Connect stops at its first path.
EST_CALL_S = {"lattice": 0.05, "astar_shortcut": 0.03, "rrt_seed003": 0.01, "pair": 0.25}
EST_ANYTIME_FACTOR, EST_RRTCONNECT_FACTOR = 1.07, 0.1


def default_worlds() -> list:
    """Every shipped world by name, then the real maps as paths relative to the checkout."""
    shipped = sorted(p.stem for p in (TOP / "worlds").glob("*.yaml"))
    return shipped + [f"../shared/worlds/{name}.yaml" for name in REAL_MAPS]


def open_world(name: str):
    """DESIGN §9: a name in worlds/ or a path (relative paths from the checkout's root)."""
    p = Path(name)
    if p.suffix in (".yaml", ".yml") and not p.is_absolute():
        p = (TOP / p).resolve()
    return load_world(p if p.suffix in (".yaml", ".yml") else name)


def navigator_lattice() -> LatticeSettings:
    return from_dict(LatticeSettings, load_yaml(SHARE_DIR / "config" / "lattice.yaml"), "config/lattice.yaml")


def reference_lattice(robot) -> LatticeSettings:
    """The lattice whose cost is the driven length: no graded cost, turns free, backward moves
    at the forward cost; the navigator's margins, so it reaches exactly where the navigator does."""
    return replace(navigator_lattice(), cost_weight=0.0, turn_speed_radps=1e9,
                   reverse_speed_mps=robot.max_linear_mps).with_robot(robot)


# ---------------------------------------------------------------------- pairs
@dataclass(frozen=True)
class Pair:
    index: int
    start: tuple        # (x, y, yaw) m, rad: a lattice pose
    goal: tuple         # (x, y, yaw): the reference plan's last pose
    reference_m: float  # the reference plan's driven length


def sample_pairs(occ: np.ndarray, res: float, origin, robot, n: int, seed: int, tries_per_pair: int = 200) -> list:
    """``n`` pairs (module docstring); RuntimeError when fewer are found in ``tries_per_pair * n`` draws."""
    rng = np.random.default_rng(seed)
    nav, ref = navigator_lattice(), reference_lattice(robot)
    spare = replace(nav, margin_m=nav.margin_m + SPARE_M)
    yaws = np.array([h[2] for h in _native.lattice_headings(nav.headings)])
    free = np.argwhere(occ == 0)
    pairs, tries = [], 0
    while len(pairs) < n:
        tries += 1
        if tries > tries_per_pair * n:
            raise RuntimeError(f"only {len(pairs)} of {n} pairs in {tries - 1} draws")
        r, c = free[rng.integers(len(free))]
        start = (*geometry.cell_to_xy((r, c), res, origin), float(yaws[rng.integers(len(yaws))]))
        if not footprint_clear(occ, res, origin, robot, np.array([start]), spare)[0]:
            continue
        reach = lattice_cost_to_come(occ, res, origin, robot, start, ref, snap_radius_m=0.0, turns_within_m=0.0)
        far = np.argwhere(np.isfinite(reach))
        if len(far) == 0:
            continue
        centres = geometry.cells_to_points(far, res, origin)
        far = far[np.hypot(*(centres - start[:2]).T) >= MIN_PAIR_DISTANCE_M]
        if len(far) == 0:
            continue
        goal_xy = geometry.cell_to_xy(far[rng.integers(len(far))], res, origin)
        try:
            path = plan_lattice(occ, res, origin, robot, start, goal_xy, ref)
        except PlanningError:
            continue
        goal = (*goal_xy, float(path.poses[-1, 2]))
        if not footprint_clear(occ, res, origin, robot, np.array([goal]), spare)[0]:
            continue
        pairs.append(Pair(len(pairs), tuple(round(v, 6) for v in start), goal, float(path.length_m)))
    return pairs


# ---------------------------------------------------------------------- the collision check
def densify(path: np.ndarray, res: float, robot, backward=None) -> np.ndarray:
    """(m, 3) poses of the robot driving ``path`` turn-drive-turn, as the navigator's follower
    does: from each pose it turns in place to the next segment's direction (the opposite one
    where ``backward[i]``, bool (n,): the segment into pose i is driven backward, as the
    lattice's and plan_sampling's ``reversed``), drives straight, and turns to the next pose's
    yaw. (n, 2) points (the 2-D planners, which know no heading) face along each segment, from
    the first, forward. Poses every <= res / 2 of travel and of the arc of the body's farthest
    point (radius_m) when turning."""
    path = np.asarray(path, dtype=float)
    if path.shape[1] == 2:
        step = np.diff(path, axis=0)
        path = path[np.r_[True, np.hypot(step[:, 0], step[:, 1]) > 1e-9]]
        step = np.diff(path, axis=0)
        heading = np.arctan2(step[:, 1], step[:, 0])
        path = np.column_stack([path, np.r_[heading[:1], heading] if len(heading) else np.zeros(len(path))])
    backward = np.zeros(len(path), bool) if backward is None else np.asarray(backward, bool)
    keys = [path[0]]        # poses where a pure turn or a pure drive ends; yaw unwrapped
    for a, b, back in zip(path[:-1], path[1:], backward[1:]):
        d, yaw = b[:2] - a[:2], keys[-1][2]
        if np.hypot(*d) > 1e-9:
            h = math.atan2(d[1], d[0]) + (math.pi if back else 0.0)
            yaw += geometry.wrap_angle(h - yaw)
            keys += [np.array([a[0], a[1], yaw]), np.array([b[0], b[1], yaw])]
        keys += [np.array([b[0], b[1], yaw + geometry.wrap_angle(b[2] - yaw)])]
    keys = np.array(keys)
    d_xy = np.hypot(*np.diff(keys[:, :2], axis=0).T)
    d_yaw = np.diff(keys[:, 2])
    n = np.ceil(np.maximum(d_xy, np.abs(d_yaw) * robot.radius_m) / (0.5 * res)).astype(int)
    parts = [keys[:1]]
    for i in np.flatnonzero(n):
        t = (np.arange(1, n[i] + 1) / n[i])[:, None]
        parts.append(keys[i] + t * (keys[i + 1] - keys[i]))
    return np.concatenate(parts)


def check_path(occ: np.ndarray, res: float, origin, robot, path: np.ndarray, backward=None) -> tuple:
    """(clear, min_clearance_m): whether the footprint along ``path`` (``densify``) never meets
    an obstacle cell's square (or leaves the grid), and its least distance to one (<= the cap)."""
    poses = densify(path, res, robot, backward)
    if len(poses) == 0:
        return False, 0.0
    d = _native.footprint_clearance(occ, res, (float(origin[0]), float(origin[1])), poses,
                                    max_m=CLEARANCE_CAP_M, occupied_threshold=OCCUPIED_THRESH,
                                    unknown_is_obstacle=True, **footprint_args(robot))
    return bool(d.min() > 0.0), float(d.min())


# ---------------------------------------------------------------------- the planners
def call_planner(name: str, budget_s: float, occ, res, origin, robot, pair: Pair):
    """(path, length_m, backward): path (n, 2) points or (n, 3) poses (m, rad), backward bool (n,)
    (the segment into each pose driven backward) or None (all forward); PlanningError when none."""
    if name == "lattice":
        p = plan_lattice(occ, res, origin, robot, pair.start, pair.goal[:2], navigator_lattice())
        return p.poses, p.length_m, p.reversed
    if name == "astar_shortcut":
        costmap = footprint_costmap(occ, res, robot, navigator_lattice())
        cells = plan(costmap, geometry.xy_to_cell(pair.start, res, origin), geometry.xy_to_cell(pair.goal, res, origin),
                     PlannerSettings(visit_sensitivity=0.0, shortcut=False), resolution=res)
        pts = geometry.cells_to_points(cells, res, origin)
        pts[0], pts[-1] = pair.start[:2], pair.goal[:2]     # the exact start and goal, not their cells' centres
        p = shortcut_turn_drive(occ, res, origin, robot, pts, pair.start[2], navigator_lattice())
        return p.poses, p.length_m, p.reversed
    if name == "rrt_seed003":
        p = plan_rrt_seed003(occ, res, origin, robot, pair.start[:2], pair.goal[:2], seed=pair.index)
        return p.points, p.length_m, None
    p = plan_sampling(occ, res, origin, robot, pair.start, pair.goal[:2], planner=name, budget_s=budget_s,
                      settings=navigator_lattice())
    return p.poses, p.length_m, p.reversed


def planner_keys(planners: list) -> list:
    """(key, planner, tier) for every row of the table: the OMPL planners once per tier."""
    out = []
    for p in planners:
        if p in BASE_PLANNERS:
            out.append((p, p, None))
        else:
            out.extend((f"ompl_{p}_{tier}", p, tier) for tier in TIERS)
    return out


def run_pair(world: str, real: bool, robot, occ, res, origin, pair: Pair, keys: list) -> list:
    rows = []
    for key, planner, tier in keys:
        budget = TIERS[tier][1 if real else 0] if tier else None
        row = dict(world=world, robot=robot.name, pair=pair.index, planner=key, budget_s=budget)
        t0 = time.perf_counter()
        try:
            path, length, backward = call_planner(planner, budget, occ, res, origin, robot, pair)
            row["time_ms"] = 1e3 * (time.perf_counter() - t0)
            clear, least = check_path(occ, res, origin, robot, path, backward)
            row.update(found=True, clear=clear, success=clear, length_ratio=length / pair.reference_m,
                       clearance_m=least, vertices=len(path))
            if not clear:
                row["error"] = "the footprint meets an obstacle along the path"
        except PlanningError as exc:
            row.update(time_ms=1e3 * (time.perf_counter() - t0), found=False, clear=False, success=False,
                       error=str(exc)[:200])
        rows.append(row)
    return rows


# ---------------------------------------------------------------------- figures
FIGURES = ("success_rate", "found_rate", "time_ms_median", "time_ms_p95", "length_ratio", "min_clearance_m")

# A planner's refusal of the start or goal (seed 003's RRT, OMPL's), not a search that failed.
REFUSED = re.compile(r"off the|inside an obstacle|hit-box meets|does not fit there|fits there at none|is outside the")


def failure_reason(row: dict) -> str:
    """"collision" (a path whose footprint meets an obstacle), "refused" (the planner refused
    the start or goal: seed 003's hit-box needs more room than the footprint the pairs are drawn
    for), else "no path" (none found, or the planner's own last check rejected the one it had)."""
    if row["found"]:
        return "collision"
    return "refused" if REFUSED.search(row["error"]) else "no path"


def planner_figures(rows: list) -> dict:
    ok = [r for r in rows if r["success"]]
    times = [r["time_ms"] for r in rows]
    reasons = [failure_reason(r) for r in rows if not r["success"]]
    return dict(calls=len(rows), success_rate=len(ok) / len(rows) if rows else None,
                found_rate=sum(r["found"] for r in rows) / len(rows) if rows else None,
                failures={k: reasons.count(k) for k in dict.fromkeys(reasons)},
                time_ms_median=float(np.median(times)) if times else None,
                time_ms_p95=float(np.percentile(times, 95)) if times else None,
                length_ratio=float(np.mean([r["length_ratio"] for r in ok])) if ok else None,
                min_clearance_m=float(min(r["clearance_m"] for r in ok)) if ok else None)


def headline_keys(keys: list) -> list:
    """The planners of min_success_rate: the lattice, A* + shortcut and OMPL at tier 0_2s."""
    return [k for k in keys if k in ("lattice", "astar_shortcut") or k.endswith("_0_2s")]


def summarise(rows: list, real_worlds: set) -> dict:
    """plan.json's figures from the per-call rows (module docstring)."""
    keys = list(dict.fromkeys(r["planner"] for r in rows))
    figures = {}
    per = {k: planner_figures([r for r in rows if r["planner"] == k]) for k in keys}
    for k, f in per.items():
        for name in FIGURES:
            figures[f"{name}_{k}"] = f[name]
    head = headline_keys(keys)
    figures["min_success_rate"] = min(per[k]["success_rate"] for k in head) if head else None
    figures["min_success_rate_planners"] = head
    for robot in dict.fromkeys(r["robot"] for r in rows):
        mine = [r for r in rows if r["robot"] == robot and r["planner"] in head]
        figures[f"min_success_rate_{robot.removeprefix('turtlebot3_')}"] = min(
            planner_figures([r for r in mine if r["planner"] == k])["success_rate"] for k in head) if mine else None
    ompl = [per[k]["length_ratio"] for k in keys if k.startswith("ompl_") and k.endswith("_0_2s")
            and per[k]["length_ratio"] is not None]
    figures["best_ompl_length_ratio_0_2s"] = min(ompl) if ompl else None
    figures["astar_shortcut_length_ratio"] = per.get("astar_shortcut", {}).get("length_ratio")
    real = [r["time_ms"] for r in rows if r["planner"] == "lattice" and r["world"] in real_worlds]
    figures["lattice_p95_ms_real_maps"] = float(np.percentile(real, 95)) if real else None
    for group in ("world", "robot"):
        figures[f"{group}s"] = {g: {k: planner_figures([r for r in rows if r[group] == g and r["planner"] == k])
                                    for k in keys}
                                for g in dict.fromkeys(r[group] for r in rows)}
    figures["failure_reasons"] = {k: f["failures"] for k, f in per.items()}
    figures["failures"] = [f"{r['world']} {r['robot']} #{r['pair']} {r['planner']}: {r.get('error', '')}"[:200]
                           for r in rows if not r["success"] and r["planner"] in head]
    figures["calls"] = len(rows)
    return figures


def print_table(figures: dict) -> None:
    keys = [k[len("found_rate_"):] for k in figures if k.startswith("found_rate_")]
    cols = FIGURES
    print(f"\n{'planner':<28}" + "".join(f"{c:>16}" for c in cols))
    for k in keys:
        vals = [figures[f"{c}_{k}"] for c in cols]
        print(f"{k:<28}" + "".join(f"{v:>16.3f}" if isinstance(v, float) else f"{v!s:>16}" for v in vals))
    worlds = figures["worlds"]
    print(f"\nsuccess rate per world\n{'planner':<28}" + "".join(f"{w[:11]:>12}" for w in worlds))
    for k in keys:
        print(f"{k:<28}" + "".join(f"{worlds[w][k]['success_rate']:>12.3f}" for w in worlds))


def estimate_s(planners: list, keys: list, real: bool) -> float:
    """Estimated wall seconds of one pair (EST_CALL_S; OMPL's anytime planners spend their budget)."""
    ompl = sum(TIERS[t][1 if real else 0] * (EST_RRTCONNECT_FACTOR if p == "rrtconnect" else EST_ANYTIME_FACTOR)
               for _, p, t in keys if t)
    return EST_CALL_S["pair"] + sum(EST_CALL_S.get(p, 0.0) for p in planners) + ompl


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worlds", default=",".join(default_worlds()), help="names in worlds/ or world YAML paths")
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--pairs", type=int, default=PAIRS_PER_WORLD, help="start/goal pairs per world and robot")
    ap.add_argument("--planners", default=",".join(BASE_PLANNERS + ("ompl",)),
                    help=f"of {', '.join(BASE_PLANNERS)}, ompl (all of OMPL_PLANNERS) or single OMPL planners")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--explore-3d", type=int, default=1, help="1: the 3-D check too (explore_3d.py: a TurtleBot 2 "
                    "explores the house with low furniture, the OctoMap layer on and off, side by side); 0: not")
    args = ap.parse_args()
    planners = []
    for p in (p for p in args.planners.split(",") if p):
        if p == "ompl" or p in OMPL_PLANNERS or p.removeprefix("ompl_") in OMPL_PLANNERS:
            planners += list(OMPL_PLANNERS) if p == "ompl" else [p.removeprefix("ompl_")]
        elif p in BASE_PLANNERS:
            planners.append(p)
        else:
            print(f"bench-plan: unknown planner '{p}'; choose from {', '.join(BASE_PLANNERS)}, ompl "
                  f"(all of {', '.join(OMPL_PLANNERS)}) or one of them")
            return 2
    planners = list(dict.fromkeys(planners))
    keys = planner_keys(planners)
    worlds = [w for w in args.worlds.split(",") if w]
    robots = [load_robot(r) for r in args.robots.split(",") if r]
    try:
        loaded = [open_world(w) for w in worlds]
    except WorldError as exc:
        print(f"bench-plan: {exc}")
        return 2
    real = {w.name for w in loaded if w.name in REAL_MAPS}
    est = 0.0
    for w in loaded:
        w_est = estimate_s(planners, keys, w.name in real) * args.pairs * len(robots)
        est += w_est
        print(f"bench-plan: {w.name}: {args.pairs} pairs x {len(robots)} robots, ~{w_est / 60:.1f} min", flush=True)
    print(f"bench-plan: {len(loaded)} worlds x {len(robots)} robots x {args.pairs} pairs, planners "
          f"{', '.join(k for k, _, _ in keys)}; estimated wall time ~{est / 60:.0f} min", flush=True)
    RUNS_FILE.parent.mkdir(parents=True, exist_ok=True)
    rows, t_start = [], time.monotonic()
    with RUNS_FILE.open("w") as log:
        for wi, world in enumerate(loaded):
            occ = world.occupancy()
            for ri, robot in enumerate(robots):
                t0 = time.monotonic()
                pairs = sample_pairs(occ, world.resolution, world.origin, robot, args.pairs,
                                     args.seed + 1000 * wi + ri)
                for pair in pairs:
                    for row in run_pair(world.name, world.name in real, robot, occ, world.resolution,
                                        world.origin, pair, keys):
                        rows.append(row)
                        log.write(json.dumps(row) + "\n")
                done = [r for r in rows if r["world"] == world.name and r["robot"] == robot.name]
                bad = [r["planner"] for r in done if not r["success"]]
                print(f"  [{time.monotonic() - t_start:.0f} s] {world.name} {robot.name}: {len(pairs)} pairs in "
                      f"{time.monotonic() - t0:.1f} s, failures {len(bad)}"
                      + (f" ({', '.join(f'{k} {bad.count(k)}' for k in dict.fromkeys(bad))})" if bad else ""),
                      flush=True)
    figures = summarise(rows, real)
    figures.update(octomap_figures())   # the OctoMap layer's (issue 33): per depth frame, per area
    if args.explore_3d:
        print("bench-plan: the 3-D check (explore_3d.py): a TurtleBot 2 explores the house with low furniture, "
              "the OctoMap layer on and off, side by side", flush=True)
        figures.update(explore_3d())
    figures.update(pairs_per_world=args.pairs, seed=args.seed, worlds_run=[w.name for w in loaded],
                   robots_run=[r.name for r in robots], wall_s=round(time.monotonic() - t_start, 1))
    print_table(figures)
    write("plan", figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
