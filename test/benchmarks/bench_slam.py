#!/usr/bin/env python3
"""SLAM benchmark (`make bench-slam` -> output/bench/slam.json), side by side in one run.

1. **Recorded drives** (offline, outside ROS): the simulator's wander through `house`, `office`
   and `maze` with the burger for ``--drive-s`` sim seconds at four odometry drifts (wheel slip
   per sqrt(m) of each wheel's travel): low 0.005, the default 0.01, 3x the default 0.03 and
   seed 003's "12 %" case (0.17: straight travel then errs by 12 % per metre, 1 sigma). Each log
   (rosbag with /scan, /odom, /imu) goes through the same pipeline as `make slam-log`; ATE of
   the optimised keyframes and of the odometry against the simulator's ground truth, map
   precision of the SLAM map, iSAM2 and scan-match times, memory per 1,000 keyframes. The
   12 % drive runs a second time with SLAM's odometry model (``odom_slip_std_sqrt_m``, 0.03 in
   slam.yaml) set to its slip, as a user who measured such a robot's odometry would set it.
2. **GTSAM's city10000** through the back end edge by edge: per-step time and the final error
   against the iSAM2 reference shipped with the wheel.
3. **Full explorations** (``--live``; what `make bench-slam` runs), two at a time:
   `explore_sim.launch` on the three worlds with the burger at the default drift, with SLAM
   (``slam:=true``, ``--seeds`` per world, 3), as `make bench-explore` runs them (runs in
   output/bench/slam_runs_slam/): the evaluator's ATE (the live estimate at 1 Hz) and the
   odometry's ATE on the same samples of the same run, the keyframe ATE, map precision,
   coverage, collisions and the full stack's real-time factor. (Exploration with exact
   odometry, the reference, is `make bench-explore SLAM=false`.) Then the waffle_pi's tag
   missions (``mission:=tags``) with SLAM (``--tag-worlds``, house; ``--tag-seeds``, 1: office
   adds ~20 min on 2 cores), the tags landmarks in SLAM's graph (``tag_landmarks:=true``, the
   default with SLAM: /tags at the graph's positions) and not (the tracker's own estimates)
   (runs in output/bench/slam_runs_tags_landmarks/ and slam_runs_tags_no_landmarks/): the tag
   errors with and without landmarks and the graph's landmarks (slam/landmarks) against the
   truth.

Keys (issue 17): ``ate_m_default_max`` (live SLAM, default drift, worst run; issue 31's
``ate_m_live_max``), ``ate_m_live_median_max`` (each world's median over its seeds, the worst),
``ate_ratio_odom_over_slam_min``, ``map_precision_min``, ``isam2_ms_median``/``_p99``/``_max``
(the largest run), ``scan_match_ms_median``, ``memory_mb_per_1000_keyframes``,
``city10000_ms_median``, ``city10000_max_error_m``, ``full_stack_rtf_slam``; issue 31 item 6:
``tag_error_median_m_slam`` (the median over the landmark runs of each run's median tag error;
``_max`` the worst run), ``tag_error_median_m_slam_no_landmarks``, ``landmark_error_median_m``
(slam/landmarks in x-y against the world's tags), ``tag_recall_min_slam``, ``false_tags_slam``.
"""
import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write  # noqa: E402

from turtlebot_recon.evaluation.metrics import map_precision  # noqa: E402
from turtlebot_recon.evaluation.trajectory_metrics import ate, read_tum  # noqa: E402
from turtlebot_recon.mapping.map_io import load_map  # noqa: E402
from turtlebot_recon.robot import load_robot  # noqa: E402
from turtlebot_recon.ros.bags import BagReader, write_rosbag  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402
from turtlebot_recon.sim.recorder import record_run  # noqa: E402
from turtlebot_recon.slam.datasets import run_city10000  # noqa: E402
from turtlebot_recon.slam.localization import LocalizationSettings  # noqa: E402
from turtlebot_recon.slam.offline import localize_log, run_log  # noqa: E402
from turtlebot_recon.slam.slam import SlamSettings  # noqa: E402

WORLDS = ("house", "office", "maze")
ROBOT = "turtlebot3_burger"
DRIFTS = {"low": 0.005, "default": 0.01, "3x": 0.03, "12pct": 0.17}
SWEEP = "slam_runs"
TAG_WORLDS = ("house",)             # the tags missions with SLAM by default (issue 31 item 6)
TAG_ROBOT = "turtlebot3_waffle_pi"   # the TurtleBot 3 with a camera


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def slam_offline(world, robot, run, slip: float, out_dir: Path, settings: SlamSettings, label: str) -> dict:
    """SLAM over one recorded drive's bag (wheel slip ``slip``) into ``out_dir``: its figures
    against the ground truth."""
    lid = robot.lidar
    before = rss_mb()
    res = run_log(BagReader(run.bag), out_dir, settings, robot.wheel_separation_m, (lid.x_m, lid.y_m, 0.0), log=lambda *a: None)
    grown = rss_mb() - before
    gt = read_tum(run.ground_truth)
    a_slam = ate(read_tum(out_dir / "trajectory.tum"), gt, 0.02)
    a_odom = ate(read_tum(run.odometry), gt, 0.02)
    m = load_map(out_dir / "map.yaml")
    prec = map_precision(m[0], m[1], m[2], world, world.start)
    st = res.stats
    print(f"[bench-slam] {label} odom {a_odom.rmse_m:.3f} m  slam {a_slam.rmse_m:.3f} m  "
          f"precision {prec['map_precision_occupied']:.3f}  loops {st['loop_accepted']}/{st['loop_tried']}  "
          f"{res.speedup:.0f}x real time", flush=True)
    return {
        "slip": slip, "distance_m": round(float(run.distance_m), 1), "keyframes": res.keyframes,
        "ate_odom_m": a_odom.rmse_m, "ate_slam_m": a_slam.rmse_m, "ate_slam_max_m": a_slam.max_m,
        "ratio": a_odom.rmse_m / max(a_slam.rmse_m, 1e-9),
        "map_precision_occupied": prec["map_precision_occupied"],
        "map_precision_free": prec["map_precision_free"],
        "loops": f"{st['loop_accepted']}/{st['loop_tried']}", "speedup": res.speedup,
        "isam2_ms_median": st.get("isam2_ms_median"), "isam2_ms_p99": st.get("isam2_ms_p99"),
        "isam2_ms_max": st.get("isam2_ms_max"), "scan_match_ms_median": st.get("scan_match_ms_median"),
        "gyro_scale": st.get("gyro_scale"), "rss_growth_mb": grown}


def recorded(drive_s: float, seed: int) -> dict:
    robot = load_robot(ROBOT)
    lid = robot.lidar
    out = {}
    tmp = Path(tempfile.mkdtemp(prefix="bench_slam_"))
    for w in WORLDS:
        world = load_world(w)
        runs = {}
        for level, slip in DRIFTS.items():
            d = tmp / f"{w}_{level}"
            run = record_run(world, robot, drive_s, seed=seed, odom_slip=slip, out_dir=d, bag_writer=write_rosbag)
            out[f"{w}/{level}"] = slam_offline(world, robot, run, slip, d / "slam", SlamSettings(), f"{w:7s} {level:8s}")
            runs[level] = (run, d)
            if level == "12pct":   # the same drive with SLAM's odometry model set to the robot's slip
                out[f"{w}/{level}_matched"] = slam_offline(
                    world, robot, run, slip, d / "slam_matched", SlamSettings(odom_slip_std_sqrt_m=slip),
                    f"{w:7s} {level + ' with slam.yaml odom_slip_std_sqrt_m ' + str(slip)}")
        # mode localization: the 3x-drift drive tracked in the map SLAM made of the default one
        # (both start where the world starts: the same map frame)
        run, d = runs["3x"]
        loc = localize_log(BagReader(run.bag), runs["default"][1] / "slam" / "map.yaml", d / "localization",
                           LocalizationSettings(), robot.wheel_separation_m, (lid.x_m, lid.y_m, 0.0),
                           log=lambda *a: None)
        a_loc = ate(read_tum(d / "localization" / "trajectory.tum"), read_tum(run.ground_truth), 0.02)
        st = loc.stats
        out[f"{w}/localization"] = {
            "ate_m": a_loc.rmse_m, "ate_max_m": a_loc.max_m, "updates": st["updates"],
            "fused_fraction": st["fused"] / max(st["updates"], 1), "relocalised": st["relocalised"],
            "scan_match_ms_median": st.get("scan_match_ms_median"), "speedup": loc.speedup}
        print(f"[bench-slam] {w:7s} localization (3x drift in the default run's SLAM map) ATE {a_loc.rmse_m:.3f} m "
              f"(max {a_loc.max_m:.3f}), fused {st['fused']}/{st['updates']}", flush=True)
    return out


RUN_KEYS = ("coverage_final", "coverage_aligned_final", "map_alignment", "time_to_99_s", "ate_m", "ate_odometry_m",
            "map_precision_occupied", "map_precision_free", "collisions", "rtf", "finished_reason")
TAG_KEYS = ("tags_placed", "tags_confirmed", "tag_recall", "tag_error_median_m", "tag_error_max_m", "false_tags",
            "landmarks", "landmark_error_median_m", "landmark_error_max_m", "false_landmarks")


def explorations(modes: dict, worlds, robot: str, mission: str, seeds: int, resume: bool, budget: float,
                 jobs: int, min_rtf: float = 0.0) -> dict:
    """bench_explore's runs of recon on ``worlds`` for each mode (name -> launch arguments), as
    `make bench-explore` runs them (sweeps ``slam_runs_<mode>``); "mode/world/seedN" -> the
    report's RUN_KEYS (and TAG_KEYS on a tags mission) and the keyframe ATE, or "no report".
    ``min_rtf`` > 0: bench_explore's --min-rtf (its wall limit), else its default."""
    import bench_explore
    out = {}
    for mode, args in modes.items():
        name = f"{SWEEP}_{mode}"
        argv = ["--strategies", "recon", "--worlds", ",".join(worlds), "--seeds", str(seeds), "--robot", robot,
                "--jobs", str(jobs), "--name", name, "--mission", mission, "--launch-args", args]
        argv += ["--budget", f"{budget:g}"] if budget else []
        argv += ["--resume"] if resume else []
        argv += ["--min-rtf", f"{min_rtf:g}"] if min_rtf > 0 else []
        bench_explore.main(argv)
        (bench_explore.BENCH_DIR / f"{name}.json").unlink(missing_ok=True)
        for w in worlds:
            for n in range(seeds):
                d = bench_explore.BENCH_DIR / name / w / "recon" / f"seed{n}"
                if not (d / "report.json").exists():
                    out[f"{mode}/{w}/seed{n}"] = "no report"
                    continue
                r = json.loads((d / "report.json").read_text())
                row = {k: r.get(k) for k in RUN_KEYS + (TAG_KEYS if mission == "tags" else ())}
                if (d / "trajectory.tum").exists() and (d / "ground_truth.tum").exists():
                    row["keyframe_ate_m"] = ate(read_tum(d / "trajectory.tum"), read_tum(d / "ground_truth.tum"),
                                                0.06).rmse_m
                out[f"{mode}/{w}/seed{n}"] = row
    return out


def live(seeds: int, resume: bool, budget: float, tag_worlds=TAG_WORLDS, tag_seeds: int = 1,
         min_rtf: float = 0.0) -> dict:
    """The burger's map explorations with SLAM (``seeds`` per world), then the waffle_pi's tag
    missions with SLAM (``tag_worlds``, ``tag_seeds``), its tags landmarks in the graph and
    not; all two at a time."""
    runs = explorations({"slam": "slam:=true odom_slip:=0.01"}, WORLDS, ROBOT, "map", seeds, resume, budget, 2,
                        min_rtf)
    runs.update(tag_missions(tag_worlds, tag_seeds, resume, budget, min_rtf))
    return runs


def tag_missions(worlds, seeds: int, resume: bool, budget: float, min_rtf: float = 0.0) -> dict:
    return explorations({"tags_landmarks": "slam:=true odom_slip:=0.01 tag_landmarks:=true",
                         "tags_no_landmarks": "slam:=true odom_slip:=0.01 tag_landmarks:=false"},
                        worlds, TAG_ROBOT, "tags", seeds, resume, budget, 2, min_rtf)


def summary(rec: dict, city: dict, runs: dict) -> dict:
    fig = {}
    if rec:   # the recorded drives and city10000 (not with --tags-only)
        default = [v for k, v in rec.items() if k.endswith("/default")]
        located = [v for k, v in rec.items() if k.endswith("/localization")]
        if located:
            fig["localization_ate_m_max"] = max(v["ate_m"] for v in located)
            fig["localization_fused_fraction_min"] = min(v["fused_fraction"] for v in located)
        fig["offline_ate_m_default_max"] = max(v["ate_slam_m"] for v in default)
        fig["offline_ate_ratio_odom_over_slam_min"] = min(v["ratio"] for v in default)
        fig["offline_map_precision_min"] = min(min(v["map_precision_occupied"], v["map_precision_free"]) for v in default)
        for level in DRIFTS:
            rows = [v for k, v in rec.items() if k.endswith(f"/{level}")]
            fig[f"offline_ate_m_{level}_max"] = max(v["ate_slam_m"] for v in rows)
            fig[f"offline_ate_odom_m_{level}_max"] = max(v["ate_odom_m"] for v in rows)
        matched = [v for k, v in rec.items() if k.endswith("_matched")]
        if matched:
            fig["offline_ate_m_12pct_matched_max"] = max(v["ate_slam_m"] for v in matched)
        drives = {k: v for k, v in rec.items() if not k.endswith("/localization")}
        largest = max(drives.values(), key=lambda v: v["keyframes"])
        for k in ("isam2_ms_median", "isam2_ms_p99", "isam2_ms_max"):
            fig[k] = largest[k]
        fig["isam2_keyframes_largest_run"] = largest["keyframes"]
        fig["scan_match_ms_median"] = statistics.median(v["scan_match_ms_median"] for v in drives.values())
        fig["memory_mb_per_1000_keyframes"] = 1000.0 * largest["rss_growth_mb"] / max(largest["keyframes"], 1)
        fig["slam_log_speedup_median"] = statistics.median(v["speedup"] for v in drives.values())
        fig.update({k: v for k, v in city.items() if k.startswith("city10000_")})
    tags_on = [v for k, v in runs.items() if k.startswith("tags_landmarks/") and isinstance(v, dict)]
    tags_off = [v for k, v in runs.items() if k.startswith("tags_no_landmarks/") and isinstance(v, dict)]

    def median_of(rows, key):
        values = [v[key] for v in rows if v.get(key) is not None]
        return statistics.median(values) if values else None

    if tags_on:
        # each run's median tag error (DESIGN §6), then the median over runs; and the worst run
        fig["tag_error_median_m_slam"] = median_of(tags_on, "tag_error_median_m")
        fig["tag_error_median_m_slam_max"] = max((v["tag_error_median_m"] for v in tags_on
                                                  if v.get("tag_error_median_m") is not None), default=None)
        fig["landmark_error_median_m"] = median_of(tags_on, "landmark_error_median_m")
        fig["tag_recall_min_slam"] = min((v["tag_recall"] or 0.0) for v in tags_on)
        fig["false_tags_slam"] = sum(v["false_tags"] or 0 for v in tags_on)
        fig["ate_m_tags_slam_max"] = max((v["ate_m"] for v in tags_on if v.get("ate_m") is not None), default=None)
    if tags_off:
        fig["tag_error_median_m_slam_no_landmarks"] = median_of(tags_off, "tag_error_median_m")
        fig["tag_recall_min_slam_no_landmarks"] = min((v["tag_recall"] or 0.0) for v in tags_off)
        fig["ate_m_tags_slam_no_landmarks_max"] = max((v["ate_m"] for v in tags_off if v.get("ate_m") is not None),
                                                      default=None)
    slam = [v for k, v in runs.items() if k.startswith("slam/") and isinstance(v, dict)]
    if slam:
        fig["ate_m_default_max"] = max(v["ate_m"] for v in slam if v["ate_m"] is not None)
        # issue 31: each world's median over its seeds, the worst world; and the worst run
        per_world = {}
        for key, v in runs.items():
            if key.startswith("slam/") and isinstance(v, dict) and v["ate_m"] is not None:
                per_world.setdefault(key.split("/")[1], []).append(v["ate_m"])
        fig["ate_m_live_median_by_world"] = {w: statistics.median(a) for w, a in per_world.items()}
        fig["ate_m_live_median_max"] = max(fig["ate_m_live_median_by_world"].values())
        fig["ate_m_live_max"] = fig["ate_m_default_max"]
        fig["keyframe_ate_m_default_max"] = max(v.get("keyframe_ate_m") or 0.0 for v in slam)
        fig["map_precision_min"] = min(min(v["map_precision_occupied"], v["map_precision_free"]) for v in slam)
        fig["coverage_min_slam"] = min(v["coverage_final"] for v in slam)
        aligned = [v["coverage_aligned_final"] for v in slam if v.get("coverage_aligned_final") is not None]
        fig["coverage_aligned_min_slam"] = min(aligned) if aligned else None
        fig["collisions_slam"] = sum(v["collisions"] for v in slam)
        fig["full_stack_rtf_slam"] = statistics.median(v["rtf"] for v in slam)
        # the odometry's ATE on the same samples of the same run (the evaluator's ate_odometry_m)
        fig["ate_ratio_odom_over_slam_min"] = min(v["ate_odometry_m"] / v["ate_m"] for v in slam)
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--drive-s", type=float, default=600.0, help="sim seconds of each recorded drive")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--live", action="store_true", help="also the full explorations with SLAM")
    p.add_argument("--seeds", type=int, default=3, help="seeds per world of the burger's explorations with SLAM")
    p.add_argument("--tag-worlds", default=",".join(TAG_WORLDS), help="worlds of the tag missions (comma-separated)")
    p.add_argument("--tag-seeds", type=int, default=1, help="seeds per world of the tag missions")
    p.add_argument("--budget", type=float, default=0.0, help="sim s of each exploration (0: bench-explore's rule)")
    p.add_argument("--resume", action="store_true", help="reuse finished explorations")
    p.add_argument("--tags-only", action="store_true", help="only the waffle_pi's tag missions with SLAM, landmarks "
                   "in the graph and not (slam.json then holds their keys alone, and says so in 'parts')")
    p.add_argument("--min-rtf", type=float, default=0.0, help="the explorations' wall limit: startup + budget / "
                   "this (0: bench-explore's default, 2); lower it on a loaded machine")
    p.add_argument("--recorded-from", help="take the recorded drives' and city10000's results from this earlier "
                   "slam.json instead of running them again")
    a = p.parse_args(argv)
    t0 = time.monotonic()
    if a.tags_only:
        runs = tag_missions(a.tag_worlds.split(","), a.tag_seeds, a.resume, a.budget, a.min_rtf)
        fig = summary({}, {}, runs)
        fig.update(parts=["tag missions with SLAM (--tags-only)"], runs=runs, wall_s=time.monotonic() - t0)
        write("slam", fig)
        return 0
    if a.recorded_from:
        old = json.loads(Path(a.recorded_from).read_text())
        rec = old["recorded"]
        city = {k: v for k, v in old.items() if k.startswith("city10000_")}
        city["times_ms"] = old["city10000_times_ms_every_100"]
        city.pop("city10000_times_ms_every_100")
        a.drive_s = old["drive_s"]
    else:
        rec = recorded(a.drive_s, a.seed)
        city = run_city10000()
    print(f"[bench-slam] city10000: median {city['city10000_ms_median']:.2f} ms, max error "
          f"{city['city10000_max_error_m']:.3f} m", flush=True)
    runs = live(a.seeds, a.resume, a.budget, a.tag_worlds.split(","), a.tag_seeds, a.min_rtf) if a.live else {}
    fig = summary(rec, city, runs)
    fig["recorded"] = rec
    fig["runs"] = runs
    fig["city10000_times_ms_every_100"] = city["times_ms"] if a.recorded_from else city["times_ms"][::100]
    fig["drive_s"] = a.drive_s
    fig["wall_s"] = time.monotonic() - t0
    write("slam", fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
