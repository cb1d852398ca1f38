#!/usr/bin/env python3
"""Tag detection benchmark (`make bench-tags`), both back-ends on the same frames, one core.

The simulator's camera (waffle_pi, 640 x 480, 62.2 deg) faces a tag36h11 of 0.16 m and an ArUco
6x6 of 0.10 m on the walls of a 6 x 6 m room from 0.5 to 3 m and 0 to 60 deg off their normals
(the distance x angle table). Each frame is rendered once; then each back-end detects on every
frame (``detect_ms_*``: median wall time per frame, the pose, checks and covariance included).
Position error: the detector's marker centre against the simulator's (ground truth), over the
unambiguous detections at <= 2.5 m (``tag_error_median_m``, ``tag_error_max_m``), per table cell
in ``table``. Targets (issue 16): the faster back-end <= 10 ms; median <= 0.03 m, max <= 0.10 m.
The mission figures (recall, false tags, search time, rtf with the camera) need the tags
mission, which is not built yet: they are not in this file.
"""
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


def main():
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
    write("tags", figures)


if __name__ == "__main__":
    main()
