"""The 3-D check of `make bench-plan` (issue 33 item 6): a TurtleBot 2 explores a world with
obstacles in a height band (worlds/*.yaml ``obstacles``: low boxes the depth camera's fake scan
passes over, shelves it passes under) twice side by side, the mapper's OctoMap layer on and off
(``octomap:=true|false``), each run as `make run` runs it (bench_explore.execute: its own ROS
master, tools/launch, explore_sim.launch at rtf 0, the evaluator's report). Figures:
``collisions_octomap_on`` / ``_off`` (the simulator's contact count), ``coverage_octomap_on`` /
``_off`` (DESIGN §6's coverage of F, whose obstacles include the boxes' footprints),
``time_to_99_s_octomap_on`` / ``_off`` and each run's status.

    python test/benchmarks/explore_3d.py [--world house_furniture] [--budget 1800]
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import SimpleNamespace

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_explore  # noqa: E402

WORLD = "house_furniture"       # worlds/: the house with low furniture
ROBOT = "turtlebot2"
BUDGET_S = 1800.0               # sim s, the evaluator's default budget
SEED = 0


def explore_3d(world: str = WORLD, budget_s: float = BUDGET_S, seed: int = SEED, jobs: int = 2,
               name: str = "plan_3d") -> dict:
    """Two explorations of ``world`` by the TurtleBot 2, the OctoMap layer on and off, ``jobs``
    at a time; the figures of the module docstring."""
    out = bench_explore.BENCH_DIR / name
    lock = threading.Lock()

    def one(layer: str) -> tuple:
        args = SimpleNamespace(out=out / layer, world_args={world: world}, robot_of={world: ROBOT},
                               mission="map", launch_args=f"octomap:={'true' if layer == 'on' else 'false'}",
                               startup_s=180.0, min_rtf=1.0, jobs=jobs)
        meta = bench_explore.execute("recon", world, seed, budget_s, args, lock)
        run_dir = args.out / world / "recon" / f"seed{seed}"
        report = json.loads((run_dir / "report.json").read_text()) if (run_dir / "report.json").exists() else {}
        return layer, meta, report

    figures = {"explore_3d_world": world, "explore_3d_robot": ROBOT, "explore_3d_budget_s": budget_s,
               "explore_3d_seed": seed}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for layer, meta, report in pool.map(one, ("on", "off")):
            figures[f"collisions_octomap_{layer}"] = report.get("collisions")
            figures[f"coverage_octomap_{layer}"] = report.get("coverage_final")
            figures[f"time_to_99_s_octomap_{layer}"] = report.get("time_to_99_s")
            figures[f"finished_reason_octomap_{layer}"] = report.get("finished_reason")
            figures[f"status_octomap_{layer}"] = meta["status"] + (f": {meta['reason']}" if meta["reason"] else "")
            figures[f"wall_s_octomap_{layer}"] = meta["wall_s"]
    return figures


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", default=WORLD)
    ap.add_argument("--budget", type=float, default=BUDGET_S)
    ap.add_argument("--seed", type=int, default=SEED)
    args = ap.parse_args()
    print(json.dumps(explore_3d(args.world, args.budget, args.seed), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
