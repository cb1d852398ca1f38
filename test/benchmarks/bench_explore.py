#!/usr/bin/env python3
"""Exploration benchmark (`make bench-explore`, issue 5 item 8): strategies x worlds x seeds.

Each run is `tools/launch ... explore_sim.launch` (what `make run` runs) headless (rtf:=0, lidar
only: the camera is off, as the launch file's default) with its own ROS master port
(ROS_MASTER_URI on 127.0.0.1), ROS_HOME (logs) and output directory
output/bench/<name>/<world>/<strategy>/seed<N>/ (report.json, coverage.csv, map, plots,
launch.log, run.json; --name, default explore: two sweeps in one tree at once need two names). Up to --jobs runs at a time (default: half the cores). A run is "ok" when
the evaluator ended it and wrote report.json; one that exceeds its wall-clock limit is stopped
(SIGINT, then SIGKILL) and recorded as "timeout"; one where a node died or no report appeared, as
"failed" with tools/launch's one-line reason. Neither is hidden: the aggregation
(turtlebot_recon.evaluation.benchmark) counts them as coverage 0 that never reached a milestone.
--resume reuses runs whose run.json says ok; --report runs nothing and summarises the runs of the
plan found on disk (a sweep made in several sittings, e.g. a few strategies per world, each
world's runs at one --jobs: compare within a world).

Worlds: the shipped ones and the real maps (the tuning set) and HELD_OUT (worlds nobody tuned on),
all swept by default; the table and the target figures are reported for each set apart
(benchmark.figures, held-out keys prefixed heldout_). --quick sweeps a subset for iteration
(QUICK_STRATEGIES on QUICK_WORLDS, one seed) and says so in the plan line and in "quick".

Budgets (sim seconds) follow benchmark.budget_s of each world's free area (WORLD_BUDGETS for the
maze, the depot and the office) unless --budget (all worlds) or --budgets world=s,... is given. A budget costs time only
in the runs that never finish (a stuck baseline drives until it); the runs that finish end on
their own; the reference strategies (every one but recon) end at REFERENCE_STOP_COVERAGE, as
only their time and distance to 99 % are compared. The robot is the waffle_pi unless --robot
or --robots world=robot,... says otherwise. The wall-clock limit of a run is --startup-s +
budget / --min-rtf.

Output: the tables, output/bench/<name>.json (benchmark.figures + machine + commit, and
run_commits: the commits the runs ran at, from their run.json, "+dirty" where the sources had
uncommitted changes; per world when they differ), and under output/bench/<name>/:
coverage_<world>.png and time_to_99.png.
"""
import argparse
import concurrent.futures as cf
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import TOP, commit, write  # noqa: E402

from turtlebot_recon.evaluation import benchmark as bm, distance_until  # noqa: E402
from turtlebot_recon.sim import WorldError, load_world  # noqa: E402

SHARED = TOP.parent / "shared" / "worlds"
SHIPPED = ("house", "maze", "office", "arena")
REAL = ("depot", "tb3_sandbox")
# Worlds nobody tuned on (worldgen's garden and doors): figures over them are reported apart,
# with the prefix heldout_ (benchmark.figures), as the check that the tuning did not overfit.
HELD_OUT = ("garden", "doors")
ROBOT = "turtlebot3_waffle_pi"     # every world (the lattice takes its box through the maze,
                                   # the 0.45 m doors and the rock garden's gaps)
# The reference strategies (the baselines and the oracle) end at this coverage: only their time
# and distance to 99 % are compared, and a baseline's last 1 % can take as long as the rest.
REFERENCE_STOP_COVERAGE = 0.99
# Budgets (sim s) other than the free-area rule: a maze is all corridor, driven end to end and
# back, far more per m^2 than the rooms the rule was set on (~900 s to 99 %). The depot and the
# office, where the rule gives 3,900 and 5,040 s: 4x and 2.3x the oracle's time to 99 % (451 and
# 1,187 s, sweep of 2026-11-30); every recon and density run there reached 99 % inside them, and
# a baseline that has not by then cannot be the best one. A run stuck until the rule's budget
# cost 10-14 min of wall time there.
WORLD_BUDGETS = {"maze": 1800.0, "depot": 1800.0, "office": 2700.0}
# --quick: for iteration, the default and the omniscient reference, one seed, on two tuning
# worlds and the held-out ones: 8 runs of 30-60 s of wall time each on one core. The office
# would add ~6 min (WORLDS=house,arena,office,garden,doors with QUICK=1 adds it).
QUICK_STRATEGIES = (bm.DEFAULT_STRATEGY, bm.REFERENCE)
QUICK_WORLDS = ("house", "arena") + HELD_OUT
QUICK_SEEDS = 1
BENCH_DIR = TOP / "output" / "bench"       # a sweep named N: runs and plots in N/, figures in N.json
SOURCE_PATHS = ("src", "scripts", "launch", "config", "include", "worlds", "CMakeLists.txt", "package.xml")
SHUTDOWN_REASON = "shut down before the end"   # the evaluator's finished_reason when stopped from outside
LIVE: dict = {}             # pid -> Popen of the launches running now (stopped on Ctrl-C)
STOPPING = threading.Event()
STOP_WAIT_S = 60.0          # s (wall) after SIGINT for the evaluator's partial report, then SIGKILL


def world_arg(name: str) -> str:
    """The launch file's world argument: a name in worlds/, a real map in ../shared/worlds, or a path."""
    if name in SHIPPED + HELD_OUT:
        return name
    if name in REAL:
        return str(SHARED / f"{name}.yaml")
    return str(Path(name).absolute())


def csv_list(text: str) -> list:
    return [x.strip() for x in text.split(",") if x.strip()]


def per_world(text: str) -> dict:
    """{world: value} from "world=value,world=value"."""
    out = {}
    for item in csv_list(text):
        name, _, value = item.partition("=")
        out[name.strip()] = value.strip()
    return out


def robots_for(worlds, args) -> dict:
    """{world: robot}: --robots entries, else --robot, else ROBOT."""
    given = per_world(args.robots)
    return {w: given.get(w) or args.robot or ROBOT for w in worlds}


def budgets_for(worlds: dict, args) -> dict:
    """{world: sim seconds} for {name: launch argument}: --budgets entries, else --budget,
    else WORLD_BUDGETS, else the free-area rule."""
    given = {w: float(v) for w, v in per_world(args.budgets).items()}
    out = {}
    for w, arg in worlds.items():
        if w in given:
            out[w] = given[w]
        elif args.budget:
            out[w] = float(args.budget)
        elif w in WORLD_BUDGETS:
            out[w] = WORLD_BUDGETS[w]
        else:
            world = load_world(arg)
            out[w] = bm.budget_s(float(world.free.sum()) * world.resolution ** 2)
    return out


def default_jobs() -> int:
    """Launches at a time: half the cores (a launch at rtf:=0 keeps about one core busy, and
    the explorer's wall-clock latency, which costs sim time, grows when they share one)."""
    return max(1, (os.cpu_count() or 2) // 2)


def source_commit() -> str:
    """HEAD's short hash, with "+dirty" when the sources a run uses (SOURCE_PATHS) differ from it
    (changed or untracked files): the commit its figures come from."""
    head = commit()
    try:
        changed = subprocess.run(["git", "status", "--porcelain", "--", *SOURCE_PATHS], cwd=TOP,
                                 capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return head
    return head + "+dirty" if changed.strip() else head


def free_port() -> int:
    """A TCP port free right now (the OS picks it), for one run's ROS master."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def load_series(run_dir: Path) -> tuple:
    path = run_dir / "coverage.csv"
    if not path.exists():
        return np.zeros(0), np.zeros(0)
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return (data[:, 0], data[:, 1]) if data.size else (np.zeros(0), np.zeros(0))


def load_run(strategy: str, world: str, seed: int, run_dir: Path) -> bm.Run:
    """A finished run from its directory (run.json written by this script, report.json, coverage.csv)."""
    meta = json.loads((run_dir / "run.json").read_text()) if (run_dir / "run.json").exists() else {}
    report = json.loads((run_dir / "report.json").read_text()) if (run_dir / "report.json").exists() else {}
    if report and "distance_to_99_m" not in report and (run_dir / "path.csv").exists():
        # a report from before the key (commit c10ef11 and older): the same from path.csv
        path = np.loadtxt(run_dir / "path.csv", delimiter=",", skiprows=1, ndmin=2)
        report["distance_to_99_m"] = distance_until(path, report.get("time_to_99_s"))
    status = meta.get("status", "ok" if report else "failed")
    return bm.Run(strategy, world, seed, status, report, load_series(run_dir), meta.get("reason", ""))


def stop_coverage(strategy: str) -> float:
    """The evaluator's stop_coverage for ``strategy``: recon runs until it says it is done."""
    return 0.0 if strategy == bm.DEFAULT_STRATEGY else REFERENCE_STOP_COVERAGE


def execute(strategy: str, world: str, seed: int, budget: float, args, lock: threading.Lock) -> dict:
    """One launch, waited for (or stopped at its wall-clock limit); returns run.json's content."""
    run_dir = args.out / world / strategy / f"seed{seed}"
    shutil.rmtree(run_dir, ignore_errors=True)
    ros_home = run_dir / "ros_home"
    ros_home.mkdir(parents=True)
    with lock:                                    # one port pick at a time within this process
        port = free_port()
    env = {**os.environ, "ROS_MASTER_URI": f"http://127.0.0.1:{port}", "ROS_IP": "127.0.0.1",
           "ROS_HOME": str(ros_home), "ROS_LOG_DIR": str(ros_home / "log")}
    env.pop("ROS_HOSTNAME", None)
    cmd = [str(TOP / "tools" / "launch"), "--tag", f"{world}/{strategy}/seed{seed}", "--done", "evaluator",
           "--report", str(run_dir / "report.json"), "explore_sim.launch", f"world:={args.world_args[world]}",
           f"robot:={args.robot_of[world]}", f"strategy:={strategy}", f"mission:={args.mission}", f"seed:={seed}", f"budget:={budget:g}", "rtf:=0",
           f"stop_coverage:={stop_coverage(strategy):g}", f"output:={run_dir}", "end_with_evaluator:=false",
           *args.launch_args.split()]
    limit_s = args.startup_s + budget / args.min_rtf
    t0 = time.monotonic()
    with open(run_dir / "launch.log", "wb") as log:
        with lock:
            if STOPPING.is_set():
                raise RuntimeError("interrupted before it started")
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
            LIVE[proc.pid] = proc
        try:
            rc, timed_out = proc.wait(timeout=limit_s), False
        except subprocess.TimeoutExpired:
            timed_out = True
            rc = stop(proc)
        finally:
            LIVE.pop(proc.pid, None)
    wall_s = time.monotonic() - t0
    # tools/launch's last line says how the launch ended ("failed: node X exited with status N: why")
    lines = (run_dir / "launch.log").read_text(errors="replace").strip().splitlines()
    last = lines[-1].split("] ", 1)[-1] if lines else ""
    died = rc not in (0, 130) and not timed_out
    report = json.loads((run_dir / "report.json").read_text()) if (run_dir / "report.json").exists() else {}
    has_report = bool(report) and report.get("finished_reason") != SHUTDOWN_REASON
    if STOPPING.is_set() and not has_report:
        status, reason = "failed", "interrupted (Ctrl-C)"
    elif timed_out and not has_report:
        status, reason = "timeout", f"stopped after the wall-clock limit of {limit_s:.0f} s"
    elif died:
        status, reason = "failed", last
    elif not has_report:
        status, reason = "failed", f"no report.json (launch exit status {rc})"
    else:         # the evaluator ended the run (if only just before the limit: a slow shutdown)
        status, reason = "ok", ""
    meta = {"status": status, "reason": reason, "returncode": rc, "wall_s": round(wall_s, 1), "port": port,
            "wall_limit_s": round(limit_s, 1), "budget_s": budget, "stop_coverage": stop_coverage(strategy),
            "jobs": args.jobs, "commit": source_commit(), "mission": args.mission,
            "command": " ".join(cmd)}
    (run_dir / "run.json").write_text(json.dumps(meta, indent=2) + "\n")
    return meta


def stop(proc: subprocess.Popen) -> int:
    """SIGINT the launch's process group (the evaluator writes a partial report), SIGKILL after
    STOP_WAIT_S; return the exit code."""
    try:
        os.killpg(proc.pid, signal.SIGINT)
        return proc.wait(timeout=STOP_WAIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.wait()
    except ProcessLookupError:              # already gone
        return proc.wait()


def reusable(strategy: str, world: str, seed: int, budget: float, args) -> bool:
    """--resume: a run that finished ok with the same robot and budget."""
    run_dir = args.out / world / strategy / f"seed{seed}"
    if not (run_dir / "report.json").exists() or not (run_dir / "run.json").exists():
        return False
    run = load_run(strategy, world, seed, run_dir)
    meta = json.loads((run_dir / "run.json").read_text())
    return (run.ok and run.report.get("robot") == args.robot_of[world] and meta.get("budget_s") == budget
            and meta.get("stop_coverage", 0.0) == stop_coverage(strategy))


def sweep(plan: list, budgets: dict, args) -> list:
    """Run (or, with --resume, reuse) every (strategy, world, seed) of ``plan``; return Runs."""
    todo, lock, done = [], threading.Lock(), 0
    for s, w, n in plan:
        if args.resume and reusable(s, w, n, budgets[w], args):
            print(f"[bench-explore] reuse {w}/{s}/seed{n}")
        else:
            todo.append((s, w, n))
    print(f"[bench-explore] {args.plan_line}: {len(todo)} runs to do ({len(plan) - len(todo)} reused), {args.jobs} at a time, "
          "budgets and robots: " + ", ".join(f"{w} {b:g} s {args.robot_of[w]}" for w, b in budgets.items()), flush=True)
    t0 = time.monotonic()
    pool = cf.ThreadPoolExecutor(max_workers=args.jobs)
    futures = {pool.submit(execute, s, w, n, budgets[w], args, lock): (s, w, n) for s, w, n in todo}
    try:
        for fut in cf.as_completed(futures):
            s, w, n = futures[fut]
            done += 1
            try:
                meta = fut.result()
            except Exception as exc:           # a bug here must not lose the rest of the sweep
                meta = {"status": "failed", "reason": f"runner error: {exc!r}", "wall_s": float("nan")}
                run_dir = args.out / w / s / f"seed{n}"
                run_dir.mkdir(parents=True, exist_ok=True)
                (run_dir / "run.json").write_text(json.dumps(meta, default=str) + "\n")
            run = load_run(s, w, n, args.out / w / s / f"seed{n}")
            cov = run.report.get("coverage_final")
            print(f"[bench-explore] {done}/{len(todo)} {w}/{s}/seed{n}: {meta['status']}"
                  f"{' (' + meta['reason'] + ')' if meta['reason'] else ''}, coverage "
                  f"{'-' if cov is None else f'{100 * cov:.1f} %'}, {meta['wall_s']:.0f} s wall "
                  f"(sweep {time.monotonic() - t0:.0f} s)", flush=True)
    except KeyboardInterrupt:              # the launches run in their own sessions: stop them here
        STOPPING.set()
        print(f"[bench-explore] interrupted: stopping {len(LIVE)} launches (finished runs stay for --resume)")
        for proc in list(LIVE.values()):
            stop(proc)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return [load_run(s, w, n, args.out / w / s / f"seed{n}") for s, w, n in plan]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--strategies", help=f"comma-separated (default: all six and {bm.REFERENCE}, the omniscient reference)")
    p.add_argument("--worlds", help="comma-separated names in worlds/, depot/tb3_sandbox (../shared/worlds) or YAML "
                                    f"paths (default: {', '.join(SHIPPED + REAL)}; held out: {', '.join(HELD_OUT)})")
    p.add_argument("--seeds", type=int, help="seeds 0..N-1 (default 3)")
    p.add_argument("--quick", action="store_true",
                   help=f"a subset for iteration: {', '.join(QUICK_STRATEGIES)} on {', '.join(QUICK_WORLDS)}, "
                        f"{QUICK_SEEDS} seed (--strategies, --worlds, --seeds still win)")
    p.add_argument("--robot", default="", help=f"for every world (default: {ROBOT})")
    p.add_argument("--robots", default="", help="per world, e.g. maze=turtlebot3_burger (wins over --robot)")
    p.add_argument("--jobs", type=int, default=default_jobs(),
                   help=f"launches at a time, each ~1 core at rtf:=0 (default: half the cores, here {default_jobs()})")
    p.add_argument("--budget", type=float, default=0.0, help="sim seconds for every world (0: the area rule)")
    p.add_argument("--budgets", default="", help="per world, e.g. house=600,office=3000 (wins over --budget)")
    p.add_argument("--min-rtf", type=float, default=2.0, help="wall limit = startup + budget / this")
    p.add_argument("--startup-s", type=float, default=120.0, help="wall seconds allowed for start-up and saving")
    p.add_argument("--name", default="explore",
                   help="the sweep's name: runs and plots in output/bench/NAME/, figures in output/bench/NAME.json "
                        "(default explore; give another for a sweep beside someone else's in the same tree)")
    p.add_argument("--mission", default="map", choices=("map", "tags"),
                   help="map: lidar coverage (the exploration figures) | tags: then the tag search "
                        "with the camera (make bench-tags)")
    p.add_argument("--launch-args", default="", help="more explore_sim.launch arguments for every run, e.g. "
                   "'slam:=true odom_slip:=0.01'")
    p.add_argument("--resume", action="store_true", help="reuse runs already finished ok")
    p.add_argument("--dry-run", action="store_true", help="print the plan, budgets and wall limits; run nothing")
    p.add_argument("--report", action="store_true",
                   help="run nothing: the table, plots and explore.json from the plan's runs already on disk "
                        "(a sweep made in several sittings; budgets and jobs as each run recorded them)")
    args = p.parse_args(argv)
    if not args.name or "/" in args.name:
        p.error("--name must be a plain file name")
    args.out = BENCH_DIR / args.name
    if args.strategies is None:
        args.strategies = ",".join(QUICK_STRATEGIES if args.quick else bm.STRATEGIES + (bm.REFERENCE,))
    if args.worlds is None:
        args.worlds = ",".join(QUICK_WORLDS if args.quick else SHIPPED + REAL + HELD_OUT)
    if args.seeds is None:
        args.seeds = QUICK_SEEDS if args.quick else 3
    strategies = csv_list(args.strategies)
    unknown = sorted(set(strategies) - set(bm.STRATEGIES) - {bm.REFERENCE})
    if unknown or not strategies:
        p.error(f"unknown strategies {unknown}; choose from {', '.join(bm.STRATEGIES)}, {bm.REFERENCE}")
    if args.seeds < 1 or args.jobs < 1 or args.min_rtf <= 0:
        p.error("--seeds, --jobs and --min-rtf must be positive")
    args.world_args = {Path(w).stem: world_arg(w) for w in csv_list(args.worlds)}   # name -> launch argument
    worlds = list(args.world_args)
    args.robot_of = robots_for(worlds, args)
    try:
        budgets = budgets_for(args.world_args, args)
    except (WorldError, ValueError) as exc:
        p.error(str(exc))
    plan = [(s, w, n) for w in worlds for s in strategies for n in range(args.seeds)]
    args.plan_line = (f"{'QUICK subset: ' if args.quick else ''}{', '.join(strategies)} on "
                      f"{', '.join(w + (' (held out)' if w in HELD_OUT else '') for w in worlds)}, "
                      f"{args.seeds} seed{'s' if args.seeds > 1 else ''}")
    if args.dry_run:
        print(f"[bench-explore] {args.plan_line}")
        for w in worlds:
            print(f"{w}: {args.world_args[w]}, {args.robot_of[w]}, budget {budgets[w]:g} s sim, wall limit "
                  f"{args.startup_s + budgets[w] / args.min_rtf:.0f} s per run, {len(strategies) * args.seeds} runs")
        print(f"{len(plan)} runs, {args.jobs} at a time, into {args.out}/")
        return
    jobs = args.jobs
    if args.report:
        plan = [(s, w, n) for s, w, n in plan if (args.out / w / s / f"seed{n}" / "run.json").exists()]
        metas = [json.loads((args.out / w / s / f"seed{n}" / "run.json").read_text()) for s, w, n in plan]
        budgets.update({w: m["budget_s"] for (_, w, _), m in zip(plan, metas)})
        jobs = sorted({m.get("jobs") for m in metas}, key=str)
        jobs = jobs[0] if len(jobs) == 1 else jobs
        runs = [load_run(s, w, n, args.out / w / s / f"seed{n}") for s, w, n in plan]
    else:
        runs = sweep(plan, budgets, args) if plan else []
        metas = [json.loads(path.read_text()) if path.exists() else {} for path in
                 (args.out / w / s / f"seed{n}" / "run.json" for s, w, n in plan)]

    groups = bm.aggregate(runs)
    print("\nexploration benchmark: medians over seeds; 'never' = not reached by most seeds; "
          "failed runs count as coverage 0")
    for title, names in (("tuning worlds", [w for w in worlds if w not in HELD_OUT]),
                         ("held-out worlds (nobody tuned on them; figures heldout_*)", [w for w in worlds if w in HELD_OUT])):
        part = {k: g for k, g in groups.items() if k[1] in names}
        if part:
            print(f"\n{title}\n{bm.table(part)}")
    for r in runs:
        if not r.ok:
            print(f"  FAILED {r.world}/{r.strategy}/seed{r.seed}: {r.status} {r.reason}")
    args.out.mkdir(parents=True, exist_ok=True)
    for w in worlds:
        bm.plot_coverage_by_world(args.out / f"coverage_{w}.png", w, runs, strategies)
    bm.plot_time_bars(args.out / "time_to_99.png", groups, worlds, strategies)
    figs = bm.figures(groups, runs, held_out=HELD_OUT)
    figs.update({"seeds": args.seeds, "jobs": jobs, "quick": args.quick})
    # Which commit each figure comes from: the runs' own (run.json; "+dirty": uncommitted
    # sources), per world when they differ. "commit" (added by write) is the checkout's now.
    run_commits = {w: sorted({m.get("commit", "unrecorded") for (_, mw, _), m in zip(plan, metas) if mw == w})
                   for w in worlds}
    figs["run_commits"] = sorted({c for cs in run_commits.values() for c in cs})
    if len(figs["run_commits"]) > 1:
        figs.update({f"run_commits_{w}": cs for w, cs in run_commits.items()})
    figs.update({f"budget_s_{w}": b for w, b in budgets.items()})
    figs.update({f"robot_{w}": r for w, r in args.robot_of.items()})
    out = write(args.name, figs)
    print(f"plots: {args.out}/coverage_<world>.png, {args.out}/time_to_99.png")
    bad = [r for r in runs if not r.ok]
    if bad:
        print(f"[bench-explore] {len(bad)} of {len(runs)} runs did not finish (FAILED lines above); figures in {out}")
        return 1
    print(f"[bench-explore] done: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
