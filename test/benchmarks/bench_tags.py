#!/usr/bin/env python3
"""Tag detection benchmark (`make bench-tags`), both back-ends on the same frames, one core.

The simulator's camera (waffle_pi, 640 x 480, 62.2 deg) faces a tag36h11 of 0.16 m and an ArUco
6x6 of 0.10 m on the walls of a 6 x 6 m room from 0.5 to 3 m and 0 to 60 deg off their normals
(the distance x angle table). Each frame is rendered once; then each back-end detects on every
frame (``detect_ms_*``: median wall time per frame, the pose, checks and covariance included).
Position error: the detector's marker centre against the simulator's (ground truth), over the
unambiguous detections at <= 2.5 m (``tag_error_median_m``, ``tag_error_max_m``), per table cell
in ``table``. Targets (issue 16): the faster back-end <= 10 ms; median <= 0.03 m, max <= 0.10 m.

Then the tag missions (unless --quick): recon with ``mission:=tags`` (the waffle_pi, camera at
5 Hz, detector and tracker) on house, office, arena and the two real maps, as
``make bench-explore --mission tags`` runs them (runs in output/bench/tags_missions/): per
world the recall, false tags, the time the search took after the lidar's frontiers ran out
(``tag_search_s``) and the run's real-time factor; ``tag_recall_min``, ``false_positives``
(summed), ``tag_search_s_median`` and ``full_stack_rtf_camera`` (median). Targets: recall
100 %, 0 false, rtf >= 4x on 2 cores.
"""
import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from common import write  # noqa: E402
from conftest import room, write_world  # noqa: E402

from turtlebot_recon.perception.detector import DetectorSettings, TagDetector  # noqa: E402
from turtlebot_recon.robot import load_robot  # noqa: E402
from turtlebot_recon.sim import load_world  # noqa: E402
from turtlebot_recon.sim.simulator import TAG_PROUD_M, SimSettings, Simulator  # noqa: E402

TAGS = [{"id": 7, "family": "tag36h11", "x": 6.1, "y": 3.0, "z": 0.2, "yaw": math.pi, "size": 0.16},
        {"id": 42, "family": "aruco_6x6_100", "x": 0.1, "y": 3.0, "z": 0.2, "yaw": 0.0, "size": 0.10}]
DISTANCES_M = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
ANGLES_DEG = (0, 15, 30, 45, 60)
REPEATS = 3


def frames():
    """[(tag, distance, angle, grey image, true marker position in the optical frame)], K."""
    path = write_world(Path(tempfile.mkdtemp()), "bench_tags", room(6.0, 6.0), start=[3.0, 3.0, 0.0], tags=TAGS)
    sim = Simulator(load_world(path), load_robot("turtlebot3_waffle_pi"), SimSettings(camera_rate_hz=5.0))
    cam, out = sim.robot.camera, []
    for tag in sim.world.tags:
        for d in DISTANCES_M:
            for a in ANGLES_DEG:
                ang = tag.yaw + math.radians(a)
                ox, oy = tag.x + d * math.cos(ang), tag.y + d * math.sin(ang)
                yaw = math.atan2(tag.y - oy, tag.x - ox)
                c, s = math.cos(yaw), math.sin(yaw)
                try:
                    sim.set_pose(ox - c * cam.x_m + s * cam.y_m, oy - s * cam.x_m - c * cam.y_m, yaw)
                except ValueError:
                    continue
                T = tag.matrix()
                T[:3, 3] += TAG_PROUD_M * T[:3, 2]
                truth = (np.linalg.inv(sim.optical_pose()) @ T)[:3, 3]
                out.append((tag, d, a, cv2.cvtColor(sim.render_camera(), cv2.COLOR_RGB2GRAY), truth))
    K = sim.camera_matrix()
    sim.close()
    return out, K


MISSION_WORLDS = ("house", "office", "arena", "depot", "tb3_sandbox")
MISSION_SWEEP = "tags_missions"
MISSION_BUDGET_FACTOR = 2.0


def missions(worlds: list, seeds: int, resume: bool) -> dict:
    """Run (or with ``resume`` reuse) the tag missions; their figures."""
    import bench_explore
    # the exploration benchmark's budgets (per world) times MISSION_BUDGET_FACTOR: the search
    # after the lidar's frontiers must not be cut by a budget set for the lidar alone
    plain = bench_explore.budgets_for(bench_explore.make_plan(",".join(worlds), "recon"),
                                      sweeps=bench_explore.committed_sweeps())
    budgets = ",".join(f"{w}={MISSION_BUDGET_FACTOR * b:g}" for w, b in plain.items())
    argv = ["--mission", "tags", "--strategies", "recon", "--worlds", ",".join(worlds), "--seeds", str(seeds),
            "--jobs", "1", "--name", MISSION_SWEEP, "--budgets", budgets] + (["--resume"] if resume else [])
    bench_explore.main(argv)
    (bench_explore.BENCH_DIR / f"{MISSION_SWEEP}.json").unlink(missing_ok=True)   # its figures are below
    out, per = {}, {}
    for w in worlds:
        reports = []
        for n in range(seeds):
            path = bench_explore.BENCH_DIR / MISSION_SWEEP / w / "recon" / f"seed{n}" / "report.json"
            if path.exists():
                reports.append(json.loads(path.read_text()))
        if not reports:
            per[w] = "no report"
            continue
        def med(key):
            vals = [r[key] for r in reports if r.get(key) is not None]
            return statistics.median(vals) if vals else None
        per[w] = {k: med(k) for k in ("tags_placed", "tags_confirmed", "tag_recall", "false_tags",
                                      "tag_error_median_m", "tag_error_max_m", "tag_search_s",
                                      "time_to_99_s", "sim_time_s", "rtf", "coverage_final")}
    good = [v for v in per.values() if isinstance(v, dict)]
    def pick(key):
        return [v[key] for v in good if v.get(key) is not None]
    out["missions"] = per
    out["tag_recall_min"] = min(pick("tag_recall")) if pick("tag_recall") else None
    out["false_positives"] = sum(pick("false_tags")) if pick("false_tags") else None
    out["tag_search_s_median"] = statistics.median(pick("tag_search_s")) if pick("tag_search_s") else None
    out["full_stack_rtf_camera"] = statistics.median(pick("rtf")) if pick("rtf") else None
    out["mission_tag_error_max_m"] = max(pick("tag_error_max_m")) if pick("tag_error_max_m") else None
    out["mission_worlds"] = list(worlds)
    out["mission_seeds"] = seeds
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="the detection table only (no missions)")
    ap.add_argument("--worlds", default=",".join(MISSION_WORLDS), help="the missions' worlds")
    ap.add_argument("--seeds", type=int, default=1, help="missions per world (seeds 0..N-1)")
    ap.add_argument("--resume", action="store_true", help="reuse missions already finished ok")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    shots, K = frames()
    figures, table = {}, {}
    for backend in ("opencv", "apriltag"):
        det = TagDetector(DetectorSettings(backend=backend))
        times, errors = [], []
        for tag, d, a, gray, truth in shots:
            best = math.inf
            for _ in range(REPEATS):
                t0 = time.perf_counter()
                found = det.detect(gray, K)
                best = min(best, time.perf_counter() - t0)
            times.append(1e3 * best)
            hit = [x for x in found if x.id == tag.id and not x.ambiguous]
            err = float(np.linalg.norm(hit[0].position_m - truth)) if hit else None
            if err is not None and d <= 2.5:
                errors.append(err)
            if backend == "apriltag":
                table[f"{tag.family} {tag.size} m, {d} m, {a} deg"] = (
                    "not read" if not found else "ambiguous" if not hit else round(err, 4))
        figures[f"detect_ms_{backend}"] = statistics.median(times)
        figures[f"detect_ms_{backend}_max"] = max(times)
        figures[f"tag_error_median_m_{backend}"] = statistics.median(errors)
        figures[f"tag_error_max_m_{backend}"] = max(errors)
        figures[f"detections_{backend}"] = len(errors)
    figures["tag_error_median_m"] = figures["tag_error_median_m_apriltag"]   # the default back-end
    figures["tag_error_max_m"] = figures["tag_error_max_m_apriltag"]
    figures["frames"] = len(shots)
    figures["table"] = table
    if not args.quick:
        figures.update(missions([w.strip() for w in args.worlds.split(",") if w.strip()], args.seeds, args.resume))
    write("tags", figures)


if __name__ == "__main__":
    main()
