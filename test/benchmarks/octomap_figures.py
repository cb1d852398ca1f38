#!/usr/bin/env python3
"""The OctoMap layer's figures (issue 33): insertion time per depth frame and memory per area.

A synthetic 10 x 10 m room (walls 2.5 m high, so no ray leaves it; a low box, a shelf, a
bin) is seen by the TurtleBot 2's depth camera (config/robots/turtlebot2.yaml: 640 x 480,
62 deg, 0.287 m up) from poses along a loop 2 m inside the walls, the heading sweeping
+-0.6 rad about the direction of travel. Each depth image is rendered exactly (rays against
axis-aligned boxes), sampled at stride 4 to 160 x 120 by perception.depth.DepthCamera, moved
into the map frame; only ``OctomapLayer.insert`` is timed. Figures:

- ``octomap_insert_ms``: median insertion time of one 160 x 120 frame, wall clock (target
  <= 20 ms); ``octomap_insert_p95_ms`` beside it, and ``octomap_insert_cpu_ms``, the median of
  the inserting thread's CPU time (what the machine's other load does not inflate).
- ``octomap_mb_per_100m2``: OcTree::memoryUsage (MB = 1e6 bytes) after the drive, per 100 m²
  of the room's floor; ``octomap_floor_seen_ratio`` says how much of the floor was seen.

``octomap_figures()`` returns them (for ``make bench-plan``); run as a script, it prints them.
The renderer (``render_depth``, ``optical_pose``) also feeds test/unit/test_octomap_layer.py.
"""
import json
import math
import statistics
import sys
import time

import numpy as np

from turtlebot_recon.mapping.octomap_layer import OctomapLayer, OctomapSettings
from turtlebot_recon.perception.depth import DepthCamera, stride_for
from turtlebot_recon.robot import load_robot

ROBOT = "turtlebot2"
ROOM_M = 10.0            # m, the room's side: 100 m² of floor
WALL_HEIGHT_M = 2.5      # m, above what the camera sees within its 4 m (0.287 + 4 tan 24.4° = 2.1 m)
FAR_M = 8.0              # m, the renderer's reach: farther is no return (NaN)
# the optical frame (x right, y down, z forward) in the body frame (x forward, y left, z up)
BODY_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def box(x0, y0, z0, x1, y1, z1) -> np.ndarray:
    """An axis-aligned box, (2, 3): lower and upper corners (m, map frame)."""
    return np.array([[x0, y0, z0], [x1, y1, z1]], np.float64)


def room_boxes(side_m: float = ROOM_M, wall_height_m: float = WALL_HEIGHT_M) -> list:
    """The benchmark's room: floor (top face at z = 0), four walls 0.1 m thick, furniture."""
    t = 0.1
    return [box(-t, -t, -t, side_m + t, side_m + t, 0.0),                  # floor
            box(-t, -t, 0.0, 0.0, side_m + t, wall_height_m),             # walls
            box(side_m, -t, 0.0, side_m + t, side_m + t, wall_height_m),
            box(0.0, -t, 0.0, side_m, 0.0, wall_height_m),
            box(0.0, side_m, 0.0, side_m, side_m + t, wall_height_m),
            box(4.0, 1.0, 0.0, 4.6, 1.4, 0.15),                            # a low box
            box(8.5, 4.0, 0.30, 9.5, 6.0, 0.36),                           # a shelf
            box(1.0, 8.5, 0.0, 1.3, 8.8, 0.5)]                             # a bin


def camera_matrix(camera) -> np.ndarray:
    """The simulator's pinhole K of a robot's CameraSpec (square pixels, centred)."""
    f = camera.fx_px
    return np.array([[f, 0.0, 0.5 * (camera.width_px - 1)], [0.0, f, 0.5 * (camera.height_px - 1)],
                     [0.0, 0.0, 1.0]])


def optical_pose(x: float, y: float, yaw: float, mount_xyz) -> np.ndarray:
    """4 x 4 map ← optical frame of a camera mounted at ``mount_xyz`` (m, body frame) on a base
    at (x, y, yaw) (m, rad)."""
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    T = np.eye(4)
    T[:3, :3] = rz @ BODY_FROM_OPTICAL
    T[:3, 3] = np.array([x, y, 0.0]) + rz @ np.asarray(mount_xyz, np.float64)
    return T


def ray_hits(origin, directions: np.ndarray, boxes: list) -> np.ndarray:
    """(n,) parameter t of the nearest box face along each ray origin + t * direction (t >= 0;
    inf where none): the slab test."""
    o = np.asarray(origin, np.float64)
    t_hit = np.full(directions.shape[0], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / directions
        for b in boxes:
            t0, t1 = (b[0] - o) * inv, (b[1] - o) * inv
            near = np.nanmax(np.minimum(t0, t1), axis=1)
            far = np.nanmin(np.maximum(t0, t1), axis=1)
            hit = (near <= far) & (far > 0)
            t_hit = np.where(hit, np.minimum(t_hit, np.maximum(near, 0.0)), t_hit)
    return t_hit


def render_depth(K: np.ndarray, width: int, height: int, pose: np.ndarray, boxes: list,
                 far_m: float = FAR_M) -> np.ndarray:
    """float32 (height, width) depth (m along the optical z) of the nearest box face each pixel
    sees from ``pose`` (map ← optical), NaN where none is nearer than ``far_m``: each pixel's
    ray scaled to optical z = 1, so that its parameter is the depth."""
    v, u = np.mgrid[0:height, 0:width]
    rays = np.stack(((u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones(u.shape)), -1)
    depth = ray_hits(pose[:3, 3], rays.reshape(-1, 3) @ pose[:3, :3].T, boxes)
    depth[depth > far_m] = np.nan
    return depth.reshape(height, width).astype(np.float32)


def loop_poses(frames: int, side_m: float = ROOM_M, inset_m: float = 2.0) -> list:
    """(x, y, yaw) along the square loop ``inset_m`` inside the walls, counter-clockwise, the
    heading sweeping +-0.6 rad about the direction of travel (three sweeps a side)."""
    a, b = inset_m, side_m - inset_m
    corners = [(a, a), (b, a), (b, b), (a, b)]
    poses = []
    for i in range(frames):
        s = 4.0 * i / frames                    # sides travelled
        k, f = int(s), s - int(s)
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
        heading = math.atan2(y1 - y0, x1 - x0) + 0.6 * math.sin(2.0 * math.pi * 3.0 * f)
        poses.append((x0 + f * (x1 - x0), y0 + f * (y1 - y0), heading))
    return poses


def octomap_figures(frames: int = 120, **overrides) -> dict:
    """The figures of the module docstring over ``frames`` (>= 50) depth frames; ``overrides``:
    OctomapSettings fields that differ from config/octomap.yaml's (a sweep's)."""
    if frames < 50:
        raise ValueError(f"octomap_figures: need >= 50 frames for a median, got {frames}")
    robot = load_robot(ROBOT)
    camera = robot.camera
    settings = OctomapSettings(**overrides).with_robot(robot)   # else config/octomap.yaml's values
    K = camera_matrix(camera)
    depth_camera = DepthCamera(K, camera.width_px, camera.height_px,
                               stride_for(camera.width_px, settings.depth_columns))
    boxes = room_boxes()
    mount = (camera.x_m, camera.y_m, camera.z_m)
    clouds = []                                  # rendered and converted before any timing
    for x, y, yaw in loop_poses(frames):
        pose = optical_pose(x, y, yaw, mount)
        depth = render_depth(K, camera.width_px, camera.height_px, pose, boxes)
        clouds.append((depth_camera.points(depth, pose), pose[:3, 3].copy()))
    layer = OctomapLayer(settings)
    times_ms, cpu_ms = [], []
    for points, origin in clouds:
        t, c = time.perf_counter(), time.thread_time()
        layer.insert(points, origin)
        times_ms.append(1e3 * (time.perf_counter() - t))
        cpu_ms.append(1e3 * (time.thread_time() - c))
    # the floor voxels (centred 0.025 m up) on the room's voxel lattice, known or not
    res = settings.resolution_m
    c = np.arange(0.5 * res, ROOM_M, res)
    gx, gy = np.meshgrid(c, c)
    floor = np.stack((gx.ravel(), gy.ravel(), np.full(gx.size, 0.5 * res)), 1)
    seen = np.isfinite(layer.tree.probabilities(floor)).mean()
    return {"octomap_insert_ms": statistics.median(times_ms),
            "octomap_insert_p95_ms": float(np.percentile(times_ms, 95)),
            "octomap_insert_cpu_ms": statistics.median(cpu_ms),
            "octomap_mb_per_100m2": layer.memory_bytes / 1e6 / (ROOM_M * ROOM_M / 100.0),
            "octomap_floor_seen_ratio": float(seen),
            "octomap_leaves": layer.leaf_count,
            "octomap_points_per_frame": int(depth_camera.shape[0] * depth_camera.shape[1]),
            "octomap_frames": frames}


if __name__ == "__main__":
    json.dump(octomap_figures(int(sys.argv[1]) if len(sys.argv) > 1 else 120), sys.stdout, indent=2)
    print()
