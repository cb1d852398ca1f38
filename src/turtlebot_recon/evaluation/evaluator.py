"""The evaluator's core (``scripts/evaluator`` is its rospy node): its settings, what it collects
during a run (``RunLog``), the run's report (``run_report``: DESIGN §6 keys, then extras) and
the run directory (``write_run``, report.json last). ROS-free: the node supplies the times,
the messages' contents, the final map and the explorer's strategy name.

Frames: the ground truth is in the world frame; the robot's map frame is its start pose
(``world.start``), so a world point p is R(-yaw0) (p - t0) in the map frame (``world_to_map``).
Clock: sim seconds on the ROS clock; the report's times count from the explorer's start
(``RunLog.t0_s``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from ..config import positive, require
from ..geometry import wrap_angle
from ..planning.lattice import LatticeSettings
from ..robot import RobotSpec
from ..sim.world import World
from .coverage import CoverageTracker, world_to_map
from .trajectory_metrics import align_se2, write_tum
from .metrics import distance_until, map_precision, standing, tag_metrics
from .report import plot_coverage, plot_map, write_report

# The files of a run directory that write_run writes; the mapper saves map.pgm / map.yaml there
# before. report.json comes last: the directory is complete once it exists.
RUN_FILES = ("coverage.csv", "path.csv", "ground_truth.tum", "coverage.png", "map.png", "report.md", "report.json")


@dataclass(frozen=True)
class EvaluatorSettings:
    """config/evaluator.yaml."""
    world: str = ""                  # a name in worlds/ or a world YAML; no default: the launch
                                         # files set it (their top-level files hold its one default)
    robot: str = ""                  # F uses its footprint and lidar range; no default: the launch
                                         # files set it (their top-level files hold its one default)
    lattice: LatticeSettings = field(default_factory=LatticeSettings)   # config/lattice.yaml: F's reachability
    output_dir: str = ""                 # run directory; '' = $ROS_HOME/explore_run
    map_frame: str = "odom"
    odom_frame: str = "odom"             # with SLAM (map_frame map) the odometry's ATE is reported too
    base_frame: str = "base_footprint"
    sample_period_s: float = 2.0         # s (sim) between coverage samples
    ate_period_s: float = 1.0            # s (sim) between ATE samples (DESIGN §6: 1 Hz)
    budget_s: float = 1800.0             # s (sim) from the explorer's start; then end the run; 0 = none
    stop_coverage: float = 0.0           # end the run once coverage reaches this; 0 = never (the
                                         # benchmark's reference strategies: only their time to 99 % counts)
    seed: int = 0                        # the run's seed, for the report
    explorer_node: str = "explorer"      # its ~strategy is the run's strategy (relative: this namespace)
    start_timeout_wall_s: float = 60.0   # s (wall) to wait for the explorer before starting the clock
    save_map_timeout_s: float = 10.0     # s (wall) for /mapper/save_map
    path_step_m: float = 0.02            # m, the true path keeps a point this far from the last

    def validate(self, src: str) -> None:
        positive(src, self, "sample_period_s", "ate_period_s", "start_timeout_wall_s",
                 "save_map_timeout_s", "path_step_m")
        require(math.isfinite(self.budget_s) and self.budget_s >= 0, src, "budget_s", "must be >= 0 (0: none)")
        require(0.0 <= self.stop_coverage <= 1.0, src, "stop_coverage", "must be in [0, 1] (0: never)")


@dataclass(frozen=True, eq=False)
class FinalMap:
    """The robot's map at the end of a run, in its map frame."""
    occupancy: np.ndarray               # int8 ROS values (-1 unknown, 0..100), row 0 at origin
    resolution: float                   # m per cell
    origin: tuple                       # (x, y) m of cell (0, 0)'s outer corner
    yaml_path: Optional[str] = None     # the mapper's saved map; None: the latest /map message


class RunLog:
    """What the evaluator collects during a run: the clock's start, the true path and the
    distance driven, the ATE samples, the collisions and the goals. Times: sim s on the ROS
    clock (absolute); the node calls it from its callbacks, under its lock."""

    def __init__(self, world_start: tuple, path_step_m: float):
        self.start = tuple(world_start)        # the map frame's pose in the world (x, y, yaw)
        self.path_step_m = path_step_m
        self.t0_s: Optional[float] = None      # the explorer's start: zero of the report's clock
        self.first_truth_s: Optional[float] = None
        self.path: list = []                   # (t s, x m, y m) world, a point every path_step_m
        self.poses: list = []                  # (t s, x m, y m, yaw rad) world, every sample
        self.distance_m = 0.0                  # along every ground-truth sample, not only path's
        self.last_xy: Optional[tuple] = None   # the latest true position (world, m)
        self.ate_pairs: list = []              # (estimate x, y, true x, y), map frame, per ATE sample
        self.estimates: list = []              # (sim time s, x, y, yaw): the live estimate at each ATE sample
        self.ate_odom_sq_m2: list = []         # the same for the raw odometry (odom frame), with SLAM
        self.collisions = 0                    # the simulator's contact count
        self.collisions_at: list = []          # (x m, y m in the map frame, t s on the report's clock)
        self.goals: list = []                  # (x, y) m in the map frame, in the order sent
        self.phases: dict = {}                 # explore/phase: name -> sim time s (ROS clock) first seen

    def start_clock(self, t0_s: float) -> bool:
        """Start the report's clock at sim time ``t0_s`` unless started; whether it started now."""
        if self.t0_s is not None:
            return False
        self.t0_s = float(t0_s)
        return True

    def elapsed(self, t_s: float) -> float:
        """Sim time ``t_s`` on the report's clock (s since the explorer's start, or since 0)."""
        return t_s - (self.t0_s or 0.0)

    def truth(self, t_s: float, x: float, y: float, yaw: float = 0.0) -> None:
        """A ground-truth pose (world, m, rad) at sim time ``t_s``."""
        self.poses.append((float(t_s), float(x), float(y), float(yaw)))
        if self.first_truth_s is None:
            self.first_truth_s = t_s
        if self.last_xy is not None:
            self.distance_m += math.hypot(x - self.last_xy[0], y - self.last_xy[1])
        self.last_xy = (x, y)
        if not self.path or math.hypot(x - self.path[-1][1], y - self.path[-1][2]) >= self.path_step_m:
            self.path.append((t_s, x, y))

    def collision_count(self, count: int, t_s: float) -> Optional[tuple]:
        """The simulator's contact count at sim time ``t_s``; where (map frame, m) and when (the
        report's clock, s) a new contact happened, rounded as report.json keeps it, else None.
        Several new contacts between two messages are one entry, at the latest true position."""
        new = None
        if count > self.collisions and self.last_xy is not None:
            xy = world_to_map(np.array([self.last_xy]), self.start)[0]
            new = (round(float(xy[0]), 2), round(float(xy[1]), 2), round(self.elapsed(t_s), 1))
            self.collisions_at.append(new)
        self.collisions = int(count)
        return new

    def goal(self, xy: tuple) -> None:
        """A goal sent by the explorer (map frame, m); a repeat of the last one is not counted."""
        if not self.goals or math.dist(xy, self.goals[-1]) > 1e-3:
            self.goals.append((float(xy[0]), float(xy[1])))

    def phase(self, name: str, t_s: float) -> bool:
        """The explorer's phase ``name`` (explore/phase: "map", then "tags") seen at sim time
        ``t_s``; only its first time is kept. Whether it is new."""
        if name in self.phases:
            return False
        self.phases[name] = float(t_s)
        return True

    def ate_sample(self, estimate_xy: tuple, true_world_xy: tuple, odometry_xy: Optional[tuple] = None,
                   t_s: Optional[float] = None, estimate_yaw: float = 0.0) -> None:
        """One ATE sample: the estimated base position (map frame) vs the true one (world), m;
        with SLAM also the odometry's (odom frame: the map frame without corrections). With its
        sim time ``t_s`` the estimate is kept for estimate.tum."""
        true_xy = world_to_map(np.array([true_world_xy], float), self.start)[0]
        if t_s is not None:
            self.estimates.append((float(t_s), float(estimate_xy[0]), float(estimate_xy[1]), float(estimate_yaw)))
        self.ate_pairs.append((float(estimate_xy[0]), float(estimate_xy[1]), float(true_xy[0]), float(true_xy[1])))
        if odometry_xy is not None:
            self.ate_odom_sq_m2.append(float((odometry_xy[0] - true_xy[0]) ** 2 + (odometry_xy[1] - true_xy[1]) ** 2))

    def map_alignment(self) -> Optional[tuple]:
        """The rigid motion (x m, y m, yaw rad) that best takes the estimated positions onto the
        true ones (both map frame); None with fewer than 10 samples."""
        if len(self.ate_pairs) < 10:
            return None
        p = np.asarray(self.ate_pairs, float)
        return tuple(float(v) for v in align_se2(p[:, :2], p[:, 2:]))

    def ate_m(self) -> Optional[float]:
        """The RMSE of the ATE samples (m); None without one."""
        if not self.ate_pairs:
            return None
        p = np.asarray(self.ate_pairs, float)
        return math.sqrt(float(np.mean(np.sum((p[:, :2] - p[:, 2:]) ** 2, axis=1))))

    def poses_in_map(self) -> np.ndarray:
        """(n, 4): every ground-truth sample as (absolute sim time s, x, y, yaw) in the map
        frame: ground_truth.tum, to score SLAM's trajectory.tum with ``make slam-eval``."""
        p = np.asarray(self.poses, float).reshape(-1, 4)
        return np.column_stack([p[:, 0], world_to_map(p[:, 1:3], self.start), wrap_angle(p[:, 3] - self.start[2])])

    def path_in_map(self) -> np.ndarray:
        """(n, 3) float: the true path as path.csv holds it, sim time on the report's clock (s,
        negative before the explorer's start) and x, y in the map frame (m)."""
        p = np.asarray(self.path, float).reshape(-1, 3)
        return np.column_stack([p[:, 0] - (self.t0_s or 0.0), world_to_map(p[:, 1:], self.start)])


def end_reason(settings: EvaluatorSettings, elapsed_s: float, coverage: Optional[float]) -> Optional[str]:
    """Why the run ends at a coverage sample: ``stop_coverage`` reached (``coverage``: the
    sample's, None without a map), else ``budget_s`` of sim time spent since the explorer's
    start (``elapsed_s``); None: it goes on."""
    if coverage is not None and 0 < settings.stop_coverage <= coverage:
        return f"coverage {100 * coverage:.1f} % reached stop_coverage {settings.stop_coverage:g}"
    if settings.budget_s > 0 and elapsed_s >= settings.budget_s:
        return f"time budget {settings.budget_s:g} s spent"
    return None


def true_tags(world: World) -> list:
    """The world's tags as (family, id, x, y, z) in the map frame (x, y: ``world_to_map``)."""
    xy = world_to_map(np.array([[t.x, t.y] for t in world.tags], float).reshape(-1, 2), world.start)
    return [(t.family, t.id, float(x), float(y), t.z) for t, (x, y) in zip(world.tags, xy)]


def tag_report(world: World, tags: Optional[list]) -> dict:
    """The tag keys: null without a tag tracker, else ``tag_metrics`` against the world's tags
    (brought into the map frame)."""
    if tags is None:
        return dict.fromkeys(("tags_placed", "tags_confirmed", "tag_recall", "tag_error_median_m",
                              "tag_error_max_m", "false_tags"))
    return tag_metrics(true_tags(world), tags)


def landmark_report(world: World, landmarks: Optional[list]) -> dict:
    """Extra keys for SLAM's tag landmarks (its latest slam/landmarks: (family, id, x, y, z) in
    the map frame; None when no SLAM graph published any): how many, and their x-y error
    against the world's tags (``match_tags``; the graph is 2-D, so its z is not compared)."""
    if landmarks is None:
        return dict.fromkeys(("landmarks", "landmark_error_median_m", "landmark_error_max_m", "false_landmarks"))
    flat = [(f, i, x, y, None) for f, i, x, y, _ in landmarks]
    m = tag_metrics(true_tags(world), flat)
    return {"landmarks": m["tags_confirmed"], "landmark_error_median_m": m["tag_error_median_m"],
            "landmark_error_max_m": m["tag_error_max_m"], "false_landmarks": m["false_tags"]}


def tag_search_s(log: RunLog, end_s: float, tags: Optional[list]) -> Optional[float]:
    """Sim s from the explorer's "tags" phase (its first explore/phase "tags": lidar exploration
    over, the search for tags begun) to ``end_s``; None without a tag tracker or that phase."""
    t = log.phases.get("tags")
    if tags is None or t is None:
        return None
    return round(max(end_s - t, 0.0), 2)


def run_report(settings: EvaluatorSettings, world: World, robot: RobotSpec, coverage: CoverageTracker,
               log: RunLog, end_s: float, wall_time_s: float, reason: str, strategy: Optional[str],
               final_map: Optional[FinalMap] = None, tags: Optional[list] = None,
               landmarks: Optional[list] = None, covered_map: Optional[FinalMap] = None) -> dict:
    """report.json's content: DESIGN §6 keys, then extras. ``tags``: the confirmed tags at the
    end, (family, id, x, y, z) in the map frame; None when no tag tracker ran (tag keys null,
    and the extra ``tag_search_s``: sim s from the explorer's "tags" phase to the end, null too
    without that phase). ``landmarks``: SLAM's tags in its graph at the end, same form; None
    without (``landmark_report``'s extra keys null).
    ``end_s``: the sim time at the end (s, ROS clock); ``wall_time_s``: the run's wall time;
    ``coverage`` already holds its sample of ``covered_map`` (default ``final_map``): the map its
    other samples read, the live /map, whose values 26..64 (a wall face as often hit as missed)
    a saved map_server file writes as unknown; its seen, occupied and aligned shares are of that
    map too. Map precision is of ``final_map`` (None: no map, precision unknown).
    Extra keys ``time_standing_s`` and ``stops`` (``metrics.standing``: true ground speed under
    0.05 m/s, stops of 0.5 s or more) count over the exploration: from the explorer's start to
    the time to 99 %, or to the end of the run where 99 % was never reached. A reference run
    ends at 99 % (stop_coverage), so every strategy is compared over the same span.
    ValueError if the clock never started (the node starts it at the latest when finishing)."""
    if log.t0_s is None:
        raise ValueError("run_report: the run's clock never started (RunLog.start_clock)")
    sim_s = log.elapsed(end_s)
    report = {"world": world.name, "robot": robot.name, "seed": settings.seed, "strategy": strategy}
    report.update(coverage.summary())
    if final_map is not None:
        p = map_precision(final_map.occupancy, final_map.resolution, final_map.origin, world, world.start)
        m = final_map if covered_map is None else covered_map
        known, occupied = coverage.seen(m.occupancy, m.resolution, m.origin)
        report.update(map_precision_occupied=p["map_precision_occupied"], map_precision_free=p["map_precision_free"],
                      coverage_seen_final=known, F_marked_occupied=occupied)
        # A SLAM map is defined up to its start: a centimetre's shift of the whole map against
        # the start frame moves every wall face across the F cells beside it. Extra keys: the
        # final coverage once the map is laid on the world by the trajectory's best rigid fit.
        t = log.map_alignment()
        if t is not None:
            report.update(coverage_aligned_final=float(np.mean(coverage.covered(m.occupancy, m.resolution, m.origin, t))),
                          map_alignment=[round(v, 4) for v in t])
    d99 = distance_until(log.path_in_map(), report["time_to_99_s"])
    t99 = report["time_to_99_s"]
    standing_s, stops = standing(np.asarray(log.poses, float), log.t0_s,
                                 end_s if t99 is None else log.t0_s + t99)
    report.update({
        "ate_m": log.ate_m(),
        **tag_report(world, tags),
        "tag_search_s": tag_search_s(log, end_s, tags),   # extra key (after the DESIGN ones in report.json)
        **landmark_report(world, landmarks),             # extra keys
        "distance_m": round(log.distance_m, 3), "collisions": log.collisions,
        "sim_time_s": round(sim_s, 2), "wall_time_s": round(wall_time_s, 2),
        "rtf": round(sim_s / wall_time_s, 2) if wall_time_s > 0 else None, "finished_reason": reason,
        # extra keys
        "ate_odometry_m": (math.sqrt(float(np.mean(log.ate_odom_sq_m2))) if log.ate_odom_sq_m2
                           else log.ate_m()),       # odometry alone, on the same samples
        "map_frame": settings.map_frame,            # map with SLAM (or a saved map), odom without
        "distance_to_99_m": None if d99 is None else round(d99, 3),   # along the recorded path
        "time_standing_s": round(standing_s, 2), "stops": stops,     # to 99 % (docstring above)
        "F_cells": coverage.cells, "F_m2": round(coverage.area_m2, 2),
        "goals": len(log.goals),
        "ate_samples": len(log.ate_pairs), "sim_start_s": round(log.t0_s, 2),
        "map": None if final_map is None else final_map.yaml_path,
        "collisions_at": list(log.collisions_at),   # (x, y) m in the map frame and t s (as time_to_*) of each
    })
    return report


def title(report: dict) -> str:
    """The plots' title: world · robot · strategy."""
    return f"{report['world']} · {report['robot']} · {report['strategy']}"


def write_run(out_dir: str | Path, report: dict, coverage: CoverageTracker, log: RunLog,
              final_map: Optional[FinalMap] = None, tags: Optional[list] = None,
              world: Optional[World] = None) -> Path:
    """Write the run directory ``out_dir``: coverage.csv (sim_time_s, coverage), path.csv
    (sim_time_s, x_m, y_m: ``RunLog.path_in_map``), ground_truth.tum (``RunLog.poses_in_map``),
    estimate.tum (the live estimate at each ATE sample, map frame; when sampled), coverage.png
    (if sampled), map.png (with a final map), report.md and, last and atomically, report.json; return report.json's path.
    ``tags``: the confirmed tags as run_report's (None: no tag tracker, no tags on map.png);
    with them and ``world``, map.png shows the world's tags too, each estimate joined to its
    true tag or marked false (``report.plot_map``).
    A report.json left by an earlier run is removed first, so the directory never pairs an old
    report with new files. OSError if a file cannot be written (then there is no report.json)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").unlink(missing_ok=True)
    t, frac = coverage.series
    np.savetxt(out / "coverage.csv", np.column_stack([t, frac]), fmt=("%.2f", "%.5f"), delimiter=",",
               header="sim_time_s,coverage", comments="")
    path = log.path_in_map()
    np.savetxt(out / "path.csv", path, fmt=("%.2f", "%.3f", "%.3f"), delimiter=",",
               header="sim_time_s,x_m,y_m", comments="")
    write_tum(out / "ground_truth.tum", log.poses_in_map())
    if log.estimates:
        write_tum(out / "estimate.tum", np.asarray(log.estimates, float))
    if t.size:
        plot_coverage(out / "coverage.png", coverage, title=title(report))
    if final_map is not None:
        truth = true_tags(world) if tags is not None and world is not None else None
        plot_map(out / "map.png", final_map.occupancy, final_map.resolution, final_map.origin,
                 path_xy=path[:, 1:], goals_xy=list(log.goals), tags=tags, true_tags=truth,
                 title=title(report))
    json_path, _ = write_report(out, report)
    return json_path


def _pct(v) -> str:
    return "-" if v is None else f"{100.0 * v:.1f} %"


def _sec(v) -> str:
    return "-" if v is None else f"{v:.0f} s"


def summary_line(report: dict) -> str:
    """One terminal line of the report's main figures."""
    ate = report["ate_m"]
    return (f"{title(report)} | coverage {_pct(report['coverage_final'])} (90 % at {_sec(report['time_to_90_s'])}, "
            f"95 % at {_sec(report['time_to_95_s'])}, 99 % at {_sec(report['time_to_99_s'])}; "
            f"seen {_pct(report.get('coverage_seen_final'))}) | {report['distance_m']:.1f} m driven | "
            f"standing {report['time_standing_s']:.0f} s, {report['stops']} stops | "
            f"{report['collisions']} collisions | sim {report['sim_time_s']:.0f} s, wall {report['wall_time_s']:.0f} s, "
            f"rtf {report['rtf']} | ATE {'-' if ate is None else f'{ate:.3f} m'} | {report['finished_reason']}")
