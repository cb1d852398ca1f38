"""The simulated TurtleBot: PyBullet (DIRECT mode) world, kinematic base, lidar, camera, depth
camera, IMU.

One call to ``step()`` advances one physics step of ``1 / physics_hz`` seconds and returns the
names of the sensors due at the new time; the caller (the ROS bridge, a test, a benchmark)
reads those sensors. Nothing here blocks or knows about ROS.

The base is kinematic: each step moves it by the twist the wheels produce; PyBullet's contact
query rejects a move that would penetrate a wall, the wheels stall, and the contact counts as
a collision (and a bumper press on robots that have bumpers). The world's obstacles are boxes
between their own heights: the lidar's rays hit one only where its height lies in the box's
band, and the body collides with it only where the two overlap in height.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import pkgutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from .. import _native
from ..config import positive, require
from ..geometry import inside, wrap_angle
from ..robot import RobotSpec
from .c_output import quiet_c_output
from .drive import DiffDrive, WheelOdometry
from .markers import full_scale, marker_image
from .world import Obstacle, World, WorldError, footprint_mask

with quiet_c_output():   # pybullet prints its build time on import
    import pybullet as pb

TAG_PROUD_M = 0.002    # markers are drawn this far in front of their wall (no z-fighting)

log = logging.getLogger(__name__)

WORLD_GROUP, ROBOT_GROUP = 1, 2   # rays carry group 1, so walls must accept group 1
PENETRATION_TOL_M = 1e-4   # deeper than this, a move is blocked
RELEASE_M = 0.005          # a contact lasts until the robot is this far from every wall
BUMPER_SIDES = ("left", "centre", "right")   # kobuki_msgs/BumperEvent LEFT=0, CENTER=1, RIGHT=2
WALL_RGBA = (0.82, 0.80, 0.76, 1.0)
OBSTACLE_RGBA = (0.55, 0.36, 0.22, 1.0)   # furniture, steps: apart from the walls in the camera
DEPTH_NEAR_M = 0.05        # the depth render's near clipping plane (below every range_min_m)
FLOOR_RGBA = (0.45, 0.45, 0.47, 1.0)


@dataclass(frozen=True)
class SimSettings:
    """Simulator bridge parameters (config/sim_bridge.yaml)."""
    world: str = ""                  # a name in worlds/ or a path to a world YAML; no default: the launch
                                         # files set it (their top-level files hold its one default)
    robot: str = ""                  # a name in config/robots/ or a path; no default: the launch
                                         # files set it (their top-level files hold its one default)
    rtf: float = 0.0                     # target real-time factor; 0 = as fast as the CPU allows
    physics_hz: float = 100.0
    cmd_timeout_s: float = 0.5           # stop when no /cmd_vel arrives for this long
    cmd_sync_age_s: float = 0.11         # rtf 0 only: while the base moves, wait for a new /cmd_vel
                                         # once the last is this old (sim s): one period of the
                                         # navigator's 10 Hz loop and a physics step; 0 = never
    cmd_sync_wait_s: float = 1.0         # ... for at most this long (wall s), then run on
    cycle_sync_slack_s: float = 0.1      # rtf 0 only: step at most this far (sim s) past the time a
                                         # node's next cycle is due (sim/next_cycle: the explorer's)
                                         # until it has run, so a cycle costs no sim time
    cycle_sync_wait_s: float = 5.0       # ... waiting at most this long (wall s); 0 = never wait
    startup_realtime_s: float = 20.0     # rtf 0 only: real time until the first /cmd_vel, for at
                                         # most this long (wall s): the stack's start-up costs the
                                         # sim time it would on a robot; 0 = full speed from the start
    odom_slip_std_sqrt_m: float = 0.0    # wheel slip: std of each wheel's travel error per sqrt(m)
    odom_heading: str = "gyro"           # with slip: odometry's heading from the gyro (what the
                                         # TurtleBot3's OpenCR firmware and kobuki_node's default
                                         # use_imu_heading publish: see docs/nodes.md) | wheels; slip 0:
                                         # exact odometry
    gyro_scale_error: float = 0.015      # the gyro's scale factor error (fraction of the true rate)
    gyro_bias_radps: float = 0.00005     # its bias left after the drivers' start-up calibration
    camera_rate_hz: float = 5.0          # 0 = no camera; rendered only when due
    depth_rate_hz: float = 2.5           # 0 = no depth camera (robots with one: the TurtleBot 2)
    depth_points_stride_px: int = 2      # camera/depth/points: every this many pixels' point
    camera_renderer: str = "egl"         # the RGB camera's: egl (PyBullet's EGL plugin on Mesa) | tiny
                                         # (TinyRenderer); the depth camera alone: always tiny
    ground_truth_rate_hz: float = 10.0
    clock_rate_hz: float = 20.0          # /clock (per sim s), at most physics_hz: every node with
                                         # use_sim_time handles each message
    seed: int = 0

    def validate(self, src: str) -> None:
        positive(src, self, "physics_hz", "cmd_timeout_s", "ground_truth_rate_hz", "clock_rate_hz")
        require(self.physics_hz >= 100.0, src, "physics_hz", "must be >= 100 Hz")
        require(self.clock_rate_hz <= self.physics_hz, src, "clock_rate_hz", "must be <= physics_hz")
        require(self.cmd_sync_age_s >= 0.0, src, "cmd_sync_age_s", "must be >= 0 (0 = never wait)")
        require(self.cmd_sync_wait_s >= 0.0, src, "cmd_sync_wait_s", "must be >= 0")
        require(self.cycle_sync_slack_s >= 0.0, src, "cycle_sync_slack_s", "must be >= 0")
        require(self.cycle_sync_wait_s >= 0.0, src, "cycle_sync_wait_s", "must be >= 0 (0 = never wait)")
        require(self.startup_realtime_s >= 0.0, src, "startup_realtime_s", "must be >= 0")
        require(self.rtf >= 0.0, src, "rtf", "must be >= 0 (0 = as fast as possible)")
        require(self.odom_slip_std_sqrt_m >= 0.0, src, "odom_slip_std_sqrt_m", "must be >= 0")
        require(self.odom_heading in ("gyro", "wheels"), src, "odom_heading",
                f"must be gyro or wheels, got {self.odom_heading!r}")
        require(abs(self.gyro_scale_error) < 0.5, src, "gyro_scale_error", "must be within +-0.5 (a fraction)")
        require(self.camera_rate_hz >= 0.0, src, "camera_rate_hz", "must be >= 0")
        require(self.depth_rate_hz >= 0.0, src, "depth_rate_hz", "must be >= 0")
        require(self.depth_points_stride_px >= 1, src, "depth_points_stride_px", "must be >= 1")
        require(self.camera_renderer in ("egl", "tiny"), src, "camera_renderer", "must be egl or tiny")


@dataclass
class BumperEvent:
    side: int      # 0 left, 1 centre, 2 right
    pressed: bool
    stamp_s: float


def _z_depth(zbuf: np.ndarray, near_m: float, far_m: float) -> np.ndarray:
    """OpenGL z-buffer values d in [0, 1] of a perspective projection -> z-depth along the
    optical axis (m), float32: z = far near / (far - (far - near) d); d = 1 (nothing drawn) is far."""
    d = zbuf.astype(np.float64)
    return (far_m * near_m / (far_m - (far_m - near_m) * d)).astype(np.float32)


def _shared_stride(robot: RobotSpec) -> int:
    """k when the RGB image is k times the depth image's size in both axes (one render can
    serve both), else 0."""
    cam, dep = robot.camera, robot.depth_camera
    if cam is None or dep is None or cam.width_px % dep.width_px:
        return 0
    k = cam.width_px // dep.width_px
    return k if cam.height_px == k * dep.height_px else 0


def yaw_quaternion(yaw: float) -> tuple:
    return (0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


class Simulator:
    def __init__(self, world: World, robot: RobotSpec, settings: SimSettings):
        self.world, self.robot, self.settings = world, robot, settings
        self.dt = 1.0 / settings.physics_hz
        self.steps = 0
        seeds = np.random.SeedSequence(settings.seed).spawn(4)
        self._rng_lidar, self._rng_odom, self._rng_imu, self._rng_depth = (np.random.default_rng(s) for s in seeds)
        self.camera_on = robot.camera is not None and settings.camera_rate_hz > 0
        self.depth_on = robot.depth_camera is not None and settings.depth_rate_hz > 0
        self.renders = self.camera_on or self.depth_on   # visual shapes, floor and tags needed
        self._depth_stride = _shared_stride(robot)
        self.client = pb.connect(pb.DIRECT)
        pb.setGravity(0, 0, 0, physicsClientId=self.client)
        self._renderer = pb.ER_TINY_RENDERER
        self._first_frame = True
        # EGL for the RGB camera; the depth camera alone renders with TinyRenderer, ~4x cheaper
        # at its 160 x 120 than EGL on llvmpipe, whose cost hardly falls below 640 x 480's
        if self.camera_on and settings.camera_renderer == "egl":
            self._load_egl()   # before any body exists: the plugin only sees bodies made after it
        self.wall_boxes = self._build_walls()
        for box in world.obstacles:
            self._build_box(box)
        self._robot_id = self._build_robot()
        self._tmp = tempfile.TemporaryDirectory(prefix="turtlebot_recon_sim_")
        if self.renders:
            self._build_floor()
            for tag in world.tags:
                self._build_tag(tag)
        self.drive = DiffDrive(robot, settings.cmd_timeout_s)
        self.odom = WheelOdometry(robot.wheel_separation_m, settings.odom_slip_std_sqrt_m, self._rng_odom)
        self._clearance = world.clearance()
        self.pose = np.array(world.start, dtype=float)   # true (x, y, yaw) in the world frame
        self.twist = (0.0, 0.0)                          # true body twist (m/s, rad/s)
        self.gyro_rate = 0.0                             # IMU yaw rate: mean over its period + noise (rad/s)
        self._gyro_turn = 0.0                            # sensed turn since the last IMU sample (rad)
        self.gyro_yaw = 0.0                              # IMU orientation, integrated gyro
        self.collisions = 0
        self._contact = False
        self._bumper = [False, False, False]
        self.bumper_events: list[BumperEvent] = []
        self.distance_m = 0.0
        if self._penetrates(self.pose):
            raise WorldError(f"{world.path}: key 'start': the {robot.name} footprint at "
                             f"{tuple(round(v, 3) for v in world.start)} overlaps a wall")
        self._place(self.pose)
        lid = robot.lidar
        angles = lid.angle_min_rad + lid.angle_increment_rad * np.arange(lid.beams)
        self._beam_dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        self._periods = {"scan": lid.rate_hz, "odom": robot.odom_rate_hz, "imu": robot.imu_rate_hz,
                         "ground_truth": settings.ground_truth_rate_hz, "clock": settings.clock_rate_hz}
        if self.camera_on:
            self._periods["camera"] = settings.camera_rate_hz
        if self.depth_on:
            self._periods["depth"] = settings.depth_rate_hz
        self._periods = {k: max(1, round(settings.physics_hz / hz)) for k, hz in self._periods.items()}

    # ---------------------------------------------------------------- construction
    def _load_egl(self) -> None:
        """PyBullet's EGL renderer (Mesa llvmpipe here) is ~4x faster than TinyRenderer."""
        plugin = pkgutil.get_loader("eglRenderer")
        with quiet_c_output():   # the plugin prints its GL driver details, at loading and at the first frame
            pid = -1 if plugin is None else pb.loadPlugin(plugin.get_filename(), "_eglRendererPlugin",
                                                           physicsClientId=self.client)
            if pid >= 0:
                pb.getCameraImage(8, 8, renderer=pb.ER_BULLET_HARDWARE_OPENGL, physicsClientId=self.client)
        if pid < 0:
            log.warning("EGL renderer plugin did not load; the camera uses TinyRenderer (slower)")
        else:
            self._renderer = pb.ER_BULLET_HARDWARE_OPENGL

    def _build_walls(self) -> int:
        """One static box per merged rectangle of wall cells; returns the box count."""
        w, res, h = self.world, self.world.resolution, self.world.wall_height
        rects = _native.merge_rectangles(w.walls.astype(np.uint8))
        shapes: dict = {}
        for row, col, nr, nc in rects:
            half = (0.5 * nc * res, 0.5 * nr * res, 0.5 * h)
            key = (int(nr), int(nc))
            if key not in shapes:
                coll = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
                vis = (pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=WALL_RGBA,
                                            physicsClientId=self.client) if self.renders else -1)
                shapes[key] = (coll, vis)
            coll, vis = shapes[key]
            body = pb.createMultiBody(
                baseMass=0, baseCollisionShapeIndex=coll, baseVisualShapeIndex=vis,
                basePosition=(w.origin[0] + (col + 0.5 * nc) * res, w.origin[1] + (row + 0.5 * nr) * res, 0.5 * h),
                physicsClientId=self.client)
            pb.setCollisionFilterGroupMask(body, -1, WORLD_GROUP, WORLD_GROUP | ROBOT_GROUP,
                                          physicsClientId=self.client)
        return len(rects)

    def _build_box(self, box: Obstacle) -> int:
        """A static box over the footprint between z_min and z_max, in the walls' collision
        group (the lidar's rays and the body's contacts hit it), drawn when a camera renders.
        Returns its body id."""
        half = (0.5 * (box.x1 - box.x0), 0.5 * (box.y1 - box.y0), 0.5 * (box.z_max - box.z_min))
        coll = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        rgba = WALL_RGBA if box.z_min == 0.0 and box.z_max >= self.world.wall_height else OBSTACLE_RGBA
        vis = (pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=self.client)
               if self.renders else -1)
        body = pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=coll, baseVisualShapeIndex=vis,
                                  basePosition=(0.5 * (box.x0 + box.x1), 0.5 * (box.y0 + box.y1),
                                                0.5 * (box.z_min + box.z_max)),
                                  physicsClientId=self.client)
        pb.setCollisionFilterGroupMask(body, -1, WORLD_GROUP, WORLD_GROUP | ROBOT_GROUP,
                                      physicsClientId=self.client)
        return body

    def _build_robot(self) -> int:
        r = self.robot
        if r.is_round:
            coll = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=r.radius_m, height=r.body_height_m,
                                           physicsClientId=self.client)
        else:
            coll = pb.createCollisionShape(
                pb.GEOM_BOX, halfExtents=(0.5 * r.footprint_length_m, 0.5 * r.footprint_width_m,
                                          0.5 * r.body_height_m),
                collisionFramePosition=(r.footprint_offset_x_m, 0, 0), physicsClientId=self.client)
        # The camera sits inside the body's box and the body is placed only where a contact
        # query needs it: without a visual shape of its own PyBullet would render the collision
        # shape, where it was last placed, into the camera image. A speck under the floor instead.
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=1e-4, visualFramePosition=(0, 0, -1.0),
                                   physicsClientId=self.client)
        # Mass > 0 so that Bullet reports its contacts with the static walls; it is never stepped.
        body = pb.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=coll, baseVisualShapeIndex=vis,
                                  physicsClientId=self.client)
        pb.setCollisionFilterGroupMask(body, -1, ROBOT_GROUP, WORLD_GROUP, physicsClientId=self.client)
        return body

    def _build_floor(self) -> None:
        sx, sy = self.world.size_m
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=(0.5 * sx + 1, 0.5 * sy + 1, 0.005),
                                   rgbaColor=FLOOR_RGBA, physicsClientId=self.client)
        pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=vis,
                           basePosition=(self.world.origin[0] + 0.5 * sx, self.world.origin[1] + 0.5 * sy, -0.005),
                           physicsClientId=self.client)

    def _build_tag(self, tag) -> None:
        """A textured quad on the wall: its +z is the marker normal, +y is up."""
        tmp = Path(self._tmp.name)
        # One mesh file per tag: PyBullet caches meshes by file name and would share one texture.
        quad = tmp / f"{tag.family}_{tag.id}.obj"
        quad.write_text("v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n"
                            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
                            "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
        png = tmp / f"{tag.family}_{tag.id}.png"
        cv2.imwrite(str(png), marker_image(tag.family, tag.id))
        edge = tag.size * full_scale(tag.family)
        n = np.array([math.cos(tag.yaw), math.sin(tag.yaw), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        rot = Rotation.from_matrix(np.column_stack([np.cross(up, n), up, n]))
        vis = pb.createVisualShape(pb.GEOM_MESH, fileName=str(quad), meshScale=(edge, edge, 1.0),
                                   physicsClientId=self.client)
        body = pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=vis,
                                  basePosition=(tag.x + TAG_PROUD_M * n[0], tag.y + TAG_PROUD_M * n[1], tag.z),
                                  baseOrientation=rot.as_quat(), physicsClientId=self.client)
        tex = pb.loadTexture(str(png), physicsClientId=self.client)
        pb.changeVisualShape(body, -1, textureUniqueId=tex, rgbaColor=(1, 1, 1, 1), physicsClientId=self.client)

    # ---------------------------------------------------------------- motion
    @property
    def time_s(self) -> float:
        return self.steps * self.dt

    def set_command(self, linear_mps: float, angular_radps: float) -> str | None:
        """Latest /cmd_vel; returns a warning line when it was rejected or clamped."""
        return self.drive.set_command(linear_mps, angular_radps, self.time_s)

    def _place(self, pose) -> None:
        pb.resetBasePositionAndOrientation(self._robot_id, (pose[0], pose[1], 0.5 * self.robot.body_height_m + 0.01),
                                           yaw_quaternion(pose[2]), physicsClientId=self.client)

    def _surely_free(self, pose, margin_m: float) -> bool:
        """Cheap test on the distance field: no wall within the circumscribed radius + margin.

        Most steps end here; only near walls does PyBullet's exact contact query run.
        """
        r, c = self.world.cell(pose[0], pose[1])
        if not inside(r, c, self._clearance.shape):
            return False
        slack = self.world.resolution * 0.7072   # the point may sit anywhere in its cell
        return self._clearance[r, c] - slack >= self.robot.radius_m + margin_m

    def _nearest_contact(self, pose):
        """(signed distance m, world point on the robot) to the closest wall within RELEASE_M.

        Negative distances are penetrations (GJK/EPA on the exact shapes); None when nothing
        is that close. Leaves the body at ``pose``.
        """
        self._place(pose)
        reach = self.robot.radius_m + RELEASE_M
        top = self.robot.body_height_m + 0.01 + RELEASE_M        # _place's body top, and the margin
        lo, hi = (pose[0] - reach, pose[1] - reach, 0.0), (pose[0] + reach, pose[1] + reach, top)
        best = None
        for body, _ in pb.getOverlappingObjects(lo, hi, physicsClientId=self.client) or ():
            if body == self._robot_id:
                continue
            for c in pb.getClosestPoints(self._robot_id, body, RELEASE_M, physicsClientId=self.client):
                if best is None or c[8] < best[0]:
                    best = (c[8], c[5])
        return best

    def _penetrates(self, pose):
        """The deepest penetrating point (world xyz) of the robot at ``pose``, or None."""
        if self._surely_free(pose, 0.0):
            return None
        c = self._nearest_contact(pose)
        return c[1] if c is not None and c[0] < -PENETRATION_TOL_M else None

    def _touching(self, pose) -> bool:
        if self._surely_free(pose, RELEASE_M):
            return False
        c = self._nearest_contact(pose)
        return c is not None and c[0] < RELEASE_M

    def step(self) -> list:
        """Advance one physics step; return the names of the sensors due now."""
        v, w = self.drive.step(self.time_s, self.dt)
        x, y, yaw = self.pose
        mid = yaw + 0.5 * w * self.dt
        target = np.array([x + v * self.dt * math.cos(mid), y + v * self.dt * math.sin(mid), wrap_angle(yaw + w * self.dt)])
        moved, hit = target, None
        if v != 0.0 or w != 0.0:
            hit = self._penetrates(target)
            if hit is not None:   # blocked: try turning in place, else stay; the wheels stall
                moved = np.array([x, y, target[2]])
                if w == 0.0 or self._penetrates(moved) is not None:
                    moved = self.pose.copy()
                self.drive.stop()
            self._place(moved)
        self._touch(hit, hit is not None or (self._contact and self._touching(moved)))
        forward = (moved[0] - x) * math.cos(mid) + (moved[1] - y) * math.sin(mid)
        turn = wrap_angle(moved[2] - yaw)
        # The IMU reports the mean rate over its sample period (a real gyro's filter and
        # decimation), plus noise: integrating its samples gives the heading change up to the
        # noise, as on a robot. The orientation integrates every step; with slip on, odometry
        # takes its heading from it, as the TurtleBots' drivers do (WheelOdometry).
        # The gyro's own errors (a scale factor, a residual bias) are the unit's, fixed in a run.
        sensed = turn * (1.0 + self.settings.gyro_scale_error) + self.settings.gyro_bias_radps * self.dt
        gyro_turn = sensed + self._rng_imu.normal(0.0, self.robot.gyro_noise_std_radps) * self.dt
        gyro_heading = self.settings.odom_slip_std_sqrt_m > 0 and self.settings.odom_heading == "gyro"
        self.odom.update(forward, turn, self.dt, gyro_turn if gyro_heading else None)
        self.twist = (forward / self.dt, turn / self.dt)
        self.distance_m += abs(forward)
        self.pose = moved
        self._gyro_turn += sensed
        self.gyro_yaw = wrap_angle(self.gyro_yaw + gyro_turn)
        self.steps += 1
        due = [name for name, period in self._periods.items() if self.steps % period == 0]
        if "imu" in due:
            period = self._periods["imu"] * self.dt
            self.gyro_rate = self._gyro_turn / period + self._rng_imu.normal(0.0, self.robot.gyro_noise_std_radps)
            self._gyro_turn = 0.0
        return due

    def _touch(self, hit, touching: bool) -> None:
        """Count contact episodes; turn contacts into Kobuki-style bumper press/release events.

        An episode starts when a move is blocked and lasts until the robot is RELEASE_M clear.
        """
        now = self.time_s + self.dt
        if touching and not self._contact:
            self.collisions += 1
        self._contact = touching
        pressed = list(self._bumper) if touching else [False, False, False]
        if hit is not None:
            pressed = [False, False, False]
            x, y, yaw = self.pose
            bearing = wrap_angle(math.atan2(hit[1] - y, hit[0] - x) - yaw)
            if abs(bearing) <= math.pi / 2:   # Kobuki bumpers cover the front half
                side = 0 if bearing > math.pi / 6 else (2 if bearing < -math.pi / 6 else 1)
                pressed[side] = True
        if self.robot.bumpers:
            for side in range(3):
                if pressed[side] != self._bumper[side]:
                    self.bumper_events.append(BumperEvent(side, pressed[side], now))
        self._bumper = pressed

    def set_pose(self, x: float, y: float, yaw: float) -> None:
        """Teleport (tests and resets); raises if the footprint would overlap a wall."""
        if self._penetrates((x, y, yaw)) is not None:
            self._place(self.pose)
            raise ValueError(f"pose ({x:.2f}, {y:.2f}) overlaps a wall")
        self.pose = np.array([x, y, wrap_angle(yaw)])

    # ---------------------------------------------------------------- sensors
    def sensor_pose(self, x_m: float, y_m: float) -> tuple:
        px, py, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        return px + c * x_m - s * y_m, py + s * x_m + c * y_m, yaw

    def true_ranges(self) -> np.ndarray:
        """Noise-free lidar ranges (m); inf where nothing is hit within range_max."""
        lid = self.robot.lidar
        sx, sy, yaw = self.sensor_pose(lid.x_m, lid.y_m)
        c, s = math.cos(yaw), math.sin(yaw)
        d = self._beam_dirs @ np.array([[c, s], [-s, c]])
        frm = np.empty((lid.beams, 3))
        frm[:, 0], frm[:, 1], frm[:, 2] = sx, sy, lid.z_m
        to = frm.copy()
        to[:, :2] += d * lid.range_max_m
        hits = pb.rayTestBatch(frm.tolist(), to.tolist(), collisionFilterMask=WORLD_GROUP,
                               physicsClientId=self.client)
        frac = np.array([h[2] if h[0] >= 0 else np.inf for h in hits])
        return frac * lid.range_max_m

    def scan(self) -> np.ndarray:
        """Lidar ranges as a real driver reports them: noise, dropouts, invalid values."""
        lid = self.robot.lidar
        r = self.true_ranges()
        sigma = np.maximum(lid.noise_std_m, lid.noise_frac * np.where(np.isfinite(r), r, 0.0))
        noisy = r + self._rng_lidar.normal(0.0, 1.0, r.shape) * sigma
        valid = np.isfinite(r) & (noisy >= lid.range_min_m) & (noisy <= lid.range_max_m)
        valid &= self._rng_lidar.random(r.shape) >= lid.dropout_prob
        return np.where(valid, noisy, lid.invalid_value).astype(np.float32)

    def camera_matrix(self) -> np.ndarray:
        cam = self.robot.camera
        f = cam.fx_px
        return np.array([[f, 0.0, 0.5 * (cam.width_px - 1)], [0.0, f, 0.5 * (cam.height_px - 1)], [0.0, 0.0, 1.0]])

    def optical_pose(self) -> np.ndarray:
        """4x4 pose of the camera's optical frame (x right, y down, z forward) in the world,
        where render_camera's image is taken from."""
        cam = self.robot.camera
        x, y, yaw = self.sensor_pose(cam.x_m, cam.y_m)
        c, s = math.cos(yaw), math.sin(yaw)
        T = np.eye(4)
        T[:3, :3] = np.array([[s, 0.0, c], [-c, 0.0, s], [0.0, -1.0, 0.0]])
        T[:3, 3] = (x, y, cam.z_m)
        return T

    def render_camera(self) -> np.ndarray:
        """RGB image (height, width, 3) uint8 from the camera's current pose (pinhole, no distortion)."""
        return self.render_views(rgb=True, depth=False)[0]

    def depth_matrix(self) -> np.ndarray:
        """The depth camera's K: the RGB camera's field of view at the depth image's size."""
        dep = self.robot.depth_camera
        f = dep.fx_px(self.robot.camera.hfov_rad)
        return np.array([[f, 0.0, 0.5 * (dep.width_px - 1)], [0.0, f, 0.5 * (dep.height_px - 1)], [0.0, 0.0, 1.0]])

    def render_views(self, rgb: bool, depth: bool) -> tuple:
        """(RGB image or None, depth image or None) from the camera's current pose. The depth
        image is float32 (height, width) metres of z-depth along the optical axis (REP 118), with
        the sensor's noise, NaN where nothing returns within [range_min_m, range_max_m]. When
        both are asked for and the RGB size is a whole multiple k of the depth size, one render
        serves both: the depth is the RGB frame's z-buffer sampled every k pixels (the pixel
        k // 2 of each k x k block, whose centre is 0.5 / k of a depth pixel right of and below
        the block's: 0.125 px at k 4)."""
        cam = self.robot.camera
        image = z_m = None
        if rgb:
            rgba, zbuf = self._render(cam.width_px, cam.height_px, cam.near_m, cam.far_m)
            image = rgba[..., :3].copy()
            if depth and self._depth_stride:
                k = self._depth_stride
                z_m = _z_depth(zbuf[k // 2::k, k // 2::k], cam.near_m, cam.far_m)
        if depth and z_m is None:
            z_m = self._render_z()
        return image, (self._depth_reading(z_m) if depth else None)

    def true_depth(self) -> np.ndarray:
        """The depth image without noise (its own render at the depth camera's size): float32
        metres, NaN outside the sensor's range."""
        dep = self.robot.depth_camera
        z_m = self._render_z()
        return np.where((z_m >= dep.range_min_m) & (z_m <= dep.range_max_m), z_m, np.nan).astype(np.float32)

    def _render_z(self) -> np.ndarray:
        dep = self.robot.depth_camera
        near_m, far_m = DEPTH_NEAR_M, 1.05 * dep.range_max_m   # beyond far: nothing drawn, no return
        _, zbuf = self._render(dep.width_px, dep.height_px, near_m, far_m)
        return _z_depth(zbuf, near_m, far_m)

    def _depth_reading(self, z_m: np.ndarray) -> np.ndarray:
        """True z-depth (m) -> what the sensor reports: axial noise, NaN out of range."""
        dep = self.robot.depth_camera
        sigma = dep.noise_std_m + dep.noise_quad_per_m * np.square(np.minimum(z_m, dep.range_max_m))
        noisy = z_m + self._rng_depth.standard_normal(z_m.shape) * sigma
        valid = (noisy >= dep.range_min_m) & (noisy <= dep.range_max_m)
        return np.where(valid, noisy, np.nan).astype(np.float32)

    def _render(self, width: int, height: int, near_m: float, far_m: float) -> tuple:
        """(RGBA uint8 (height, width, 4), z-buffer float32 (height, width) in [0, 1]) of the
        camera's view at the camera's field of view, between the clipping planes near_m and far_m."""
        cam = self.robot.camera
        cx, cy, yaw = self.sensor_pose(cam.x_m, cam.y_m)
        eye = (cx, cy, cam.z_m)
        target = (cx + math.cos(yaw), cy + math.sin(yaw), cam.z_m)
        view = pb.computeViewMatrix(eye, target, (0, 0, 1), physicsClientId=self.client)
        vfov = 2.0 * math.atan(math.tan(0.5 * cam.hfov_rad) * height / width)
        proj = pb.computeProjectionMatrixFOV(math.degrees(vfov), width / height, near_m, far_m,
                                             physicsClientId=self.client)
        # the EGL plugin prints its GL vendor at the first frame
        with quiet_c_output() if self._first_frame else contextlib.nullcontext():
            _, _, rgba, zbuf, _ = pb.getCameraImage(width, height, view, proj, shadow=0,
                                                    flags=pb.ER_NO_SEGMENTATION_MASK, renderer=self._renderer,
                                                    physicsClientId=self.client)
        self._first_frame = False
        return (np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4),
                np.asarray(zbuf, dtype=np.float32).reshape(height, width))

    def add_box(self, x0: float, y0: float, x1: float, y1: float, z_min: float = 0.0,
                z_max: float | None = None) -> None:
        """A box over [x0, x1] x [y0, y1] (world frame, m) from now on, between the heights
        z_min and z_max (m; None: the walls' height): a door closing, an obstacle moved into the
        way. The lidar sees it at heights in its band, the body collides with it where they
        overlap and the world's grid (clearance, ``world.free``) includes its footprint.
        ValueError, with nothing changed, if the box is not finite, is thinner than 1 mm, has
        no height or would overlap the robot."""
        z_max = self.world.wall_height if z_max is None else z_max
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1, z_min, z_max)):
            raise ValueError(f"add_box: corners and heights must be finite, got ({x0}, {y0}), ({x1}, {y1}), "
                             f"z {z_min}-{z_max}")
        x0, x1, y0, y1 = min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)
        if x1 - x0 < 1e-3 or y1 - y0 < 1e-3:
            raise ValueError(f"add_box: ({x0}, {y0})-({x1}, {y1}) is thinner than 1 mm")
        if not 0.0 <= z_min < z_max:
            raise ValueError(f"add_box: heights must satisfy 0 <= z_min < z_max, got {z_min}-{z_max}")
        box = Obstacle(x0, y0, x1, y1, z_min, z_max)
        body = self._build_box(box)
        contact = self._nearest_contact(self.pose)
        if contact is not None and contact[0] < -PENETRATION_TOL_M:
            pb.removeBody(body, physicsClientId=self.client)
            raise ValueError(f"add_box: ({x0:.3f}, {y0:.3f})-({x1:.3f}, {y1:.3f}) overlaps the robot")
        w = self.world
        self.world = dataclasses.replace(w, free=w.free & ~footprint_mask(w, (box,)), obstacles=w.obstacles + (box,),
                                         wall_free=w.free if w.wall_free is None else w.wall_free)
        self._clearance = self.world.clearance()
        self.wall_boxes += 1

    def close(self) -> None:
        if self.client is not None and pb.isConnected(self.client):
            with quiet_c_output():   # the EGL plugin says goodbye on stdout
                pb.disconnect(self.client)
        self._tmp.cleanup()
