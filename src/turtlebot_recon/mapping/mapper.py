"""The mapper's core (ROS-free): scans, bumpers and motion into the occupancy and visit grids.

The node supplies plain data (ranges, the sensor pose in the map frame, times); everything a
real driver can send wrong is sorted here into a skipped scan or a skipped beam and counted,
so one diagnostics line says what was ignored and why.
"""
from __future__ import annotations

import dataclasses
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ..config import positive, require
from ..geometry import between, compose
from .grid import GridSettings, make_grid
from .octomap_layer import OctomapSettings

# Kobuki bumpers (kobuki_msgs/BumperEvent LEFT=0, CENTER=1, RIGHT=2): body angle of each centre.
BUMPER_ANGLE_RAD = {0: math.pi / 3, 1: 0.0, 2: -math.pi / 3}
TIME_JUMP_BACK_S = 1.0   # the clock going back this far means a restarted simulation or bag
BUMP_MAX_AGE_S = 0.5     # s, a press held for the base's pose is marked at most this much later


def _key(stamp_s: float) -> int:
    """A scan's stamp as a dictionary key (microseconds: the same stamp from two messages)."""
    return round(float(stamp_s) * 1e6)


@dataclass(frozen=True)
class MapperSettings:
    """mapper node parameters (config/mapper.yaml)."""
    map_frame: str = "odom"              # the frame the map is built in (odom until SLAM exists)
    base_frame: str = "base_footprint"
    robot: str = ""                  # for the bumper geometry (config/robots/); no default: the launch
                                         # files set it (their top-level files hold its one default)
    publish_rate_hz: float = 1.0         # /map and /visit_map
    tf_timeout_s: float = 1.0            # wait this long for the scan's transform
    map_file: str = ""                   # base path of the PGM/YAML pair ('' = ~/.ros/map)
    # The resume file (map_file + ".resume.npz", mapping/resume.py): the grid saved every
    # autosave_period_s of sim time, so that a mapper restarted mid-run (respawn) goes on from
    # it; 0 = never. resume_key names the launch (the launch files set $(anon run)): a resume
    # file written under another key is an earlier run's and is not taken.
    autosave_period_s: float = 10.0      # s (sim)
    resume_key: str = ""
    initial_map: str = ""                # a saved map (map_server YAML) to start from, in map_frame
                                         # ('' = none): a tag search on a map made before
    save_on_shutdown: bool = True
    # With SLAM (its keyframe poses on slam_path): the map is drawn again from the keyframes'
    # scans at their optimised poses once any of them has moved this far since the last drawing
    rerender_shift_m: float = 0.02       # m (under half a cell: walls drawn at two poses thicken)
    rerender_shift_rad: float = 0.01     # rad (3.5 cm at the lidar's 3.5 m)
    odom_frame: str = "odom"             # with SLAM, scans are kept with their odometry pose
    grid: GridSettings = field(default_factory=GridSettings)
    # The 3-D obstacle layer (mapping/octomap_layer.py): depth images (camera/depth/image_raw)
    # and the lidar's returns at its mounting height go into an OcTree whose obstacles between
    # the floor band and the robot's top join /map and the saved map; octomap.bt is saved
    # beside the map. Its settings: config/octomap.yaml, loaded under ~octomap
    octomap_layer: bool = False
    octomap: OctomapSettings = field(default_factory=OctomapSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "publish_rate_hz", "tf_timeout_s", "rerender_shift_m", "rerender_shift_rad")
        require(self.autosave_period_s >= 0, src, "autosave_period_s", "must be >= 0 (0 = never)")
        require(self.map_frame != self.base_frame, src, "map_frame", "must differ from base_frame")


@dataclass(frozen=True)
class Scan:
    """A LaserScan's content, in plain numbers."""
    ranges: np.ndarray        # float32, m
    angle_min: float          # rad
    angle_max: float
    angle_increment: float
    range_min: float          # m
    range_max: float
    stamp_s: float


def body_disc(robot) -> tuple:
    """(centre ahead of base_footprint m, radius m): the largest disc inside a robot's body (a
    RobotSpec); a box's is centred on the box, radius half its smaller side."""
    if robot.is_round:
        return 0.0, robot.radius_m
    return robot.footprint_offset_x_m, 0.5 * min(robot.footprint_length_m, robot.footprint_width_m)


class Mapper:
    def __init__(self, settings: MapperSettings, robot_radius_m: float,
                 body_disc: tuple | None = None, prior: tuple | None = None, resume: tuple | None = None):
        """``prior``: (occupancy int8 -1/0..100, resolution m, (origin x, y)) of a saved map the
        grid starts from (``load_map``'s tuple), at the grid's resolution; scans then update it.
        ``resume``: (log-odds float32, NaN unknown; resolution m; (origin x, y)) of the resume
        file a mapper of this run saved before it died (``resume.load_resume``): the grid starts
        as that mapper left it (``prior`` is then ignored: the resumed grid holds it)."""
        self.settings = settings
        if resume is not None:
            logodds, resolution, origin = resume
            self.prior = (self._covering(settings.grid, np.shape(logodds), resolution, origin, "resumed map"),
                          np.asarray(logodds, np.float32))
        else:
            self.prior = None if prior is None else self._prior_grid(settings.grid, *prior)
        self.robot_radius_m = robot_radius_m     # the bumpers' circle
        # (centre ahead of base_footprint m, radius m): a disc inside the body; default the
        # round body of robot_radius_m
        self.body_disc = (0.0, robot_radius_m) if body_disc is None else body_disc
        self.grid = self._new_grid()
        self.skipped = Counter()     # whole scans ignored, by reason
        self.beams = Counter()       # beams by class (valid, no_return, capped, too_close, nan)
        self.scans = 0
        self.last_clock_s = -math.inf
        # With SLAM: every inserted scan with its base's odometry pose, so that the map can be
        # drawn again after a correction, each scan moved with the keyframe before it
        self.history = []            # (stamp, base odom pose, sensor offset, Scan, sensor map pose)
        self.history_index = {}      # stamp key -> index in history
        self.drawn = {}              # keyframe stamp key -> map pose it was last drawn at (None: no scan)
        self.bumps = []              # (side, base pose in the map, base odom pose or None)
        self.held_bumps = []         # (side, sim time s): presses that came before the base's pose
        self.rerenders = 0

    def check_scan(self, scan: Scan) -> str | None:
        """Why a scan cannot be used (a reason key), or None. Counts the reason."""
        reason = None
        n = len(scan.ranges)
        if n == 0:
            reason = "empty"
        elif not all(map(math.isfinite, (scan.angle_min, scan.angle_max, scan.angle_increment,
                                         scan.range_min, scan.range_max))) \
                or scan.angle_increment == 0.0 or scan.range_max <= scan.range_min:
            reason = "bad_header"
        else:
            expected = round((scan.angle_max - scan.angle_min) / scan.angle_increment) + 1
            if abs(n - expected) > 1:   # drivers differ by one on whether angle_max is inclusive
                reason = "length_mismatch"
        if reason:
            self.skipped[reason] += 1
        return reason

    @staticmethod
    def skip_line(reason: str, scan: Scan) -> str:
        """The node's one line for a scan ``check_scan`` refused for ``reason``."""
        what = {"empty": "no ranges",
                "bad_header": "angles or range limits not finite, angle_increment 0 or range_max <= range_min",
                "length_mismatch": "the number of ranges does not match the angles"}.get(reason, reason)
        return (f"mapper: scan skipped ({reason}: {what}): {len(scan.ranges)} ranges, angles "
                f"{scan.angle_min:.3f}..{scan.angle_max:.3f} step {scan.angle_increment:.5f}, "
                f"range {scan.range_min:g}..{scan.range_max:g} m")

    def time_jumped_back(self, now_s: float) -> bool:
        """True (once) when the clock went backwards, e.g. a restarted simulation or bag.

        ``now_s`` is the node's clock, not a message stamp: a stale scan is not a clock jump.
        """
        jumped = now_s < self.last_clock_s - TIME_JUMP_BACK_S
        self.last_clock_s = now_s
        if jumped:
            self.skipped["time_jump_back"] += 1
            self.history.clear()         # a new run: its keyframes are not these
            self.history_index.clear()
            self.drawn.clear()
        return jumped

    def insert(self, scan: Scan, sensor_pose: tuple, base_odom: tuple | None = None,
               sensor_offset: tuple | None = None) -> None:
        """Insert a checked scan taken from ``sensor_pose`` = (x, y, yaw) in the map frame. With
        SLAM, ``base_odom`` (the base's odometry pose at the scan) and ``sensor_offset`` (the
        lidar in the base frame) keep it for a later redraw."""
        self._insert(self.grid, scan, sensor_pose)
        self.scans += 1
        if base_odom is not None:
            self.history_index[_key(scan.stamp_s)] = len(self.history)
            self.history.append((scan.stamp_s, tuple(base_odom), tuple(sensor_offset or (0.0, 0.0, 0.0)), scan,
                                 tuple(sensor_pose)))

    def _insert(self, grid, scan: Scan, sensor_pose: tuple) -> None:
        g = self.settings.grid
        stats = grid.insert_scan(
            sensor_pose[0], sensor_pose[1], sensor_pose[2], np.asarray(scan.ranges, np.float32),
            scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max,
            no_return_clear_m=g.no_return_clear_m, range_cap_m=g.range_cap_m)
        for key in ("valid", "no_return", "capped", "too_close", "nan"):
            if getattr(stats, key):
                self.beams[key] += getattr(stats, key)

    # ------------------------------------------------------------- SLAM keyframes
    def needs_redraw(self, stamps, base_poses) -> bool:
        """Whether SLAM's keyframes (their scans' stamps, optimised base poses in the map frame)
        moved far enough from where the map last drew them to draw it again. A keyframe new to
        the mapper was drawn already (at nearly that pose); one whose scan the mapper never
        inserted is counted and left out."""
        moved = False
        for stamp, pose in zip(stamps, np.asarray(base_poses, float).reshape(-1, 3)):
            key = _key(stamp)
            if key not in self.drawn:
                if key not in self.history_index:
                    self.skipped["keyframe_scan_missing"] += 1
                self.drawn[key] = tuple(pose) if key in self.history_index else None
                continue
            old = self.drawn[key]
            if old is None:
                continue
            d = between(old, pose)
            if math.hypot(d[0], d[1]) > self.settings.rerender_shift_m or abs(d[2]) > self.settings.rerender_shift_rad:
                moved = True
        return moved

    def redraw(self, stamps, base_poses):
        """A new grid drawn from every kept scan, each at its keyframe's corrected pose composed
        with the odometry from that keyframe to the scan (SLAM's own map -> odom, piece by
        piece), with the robot's track (visits, the floor under the body) and the bumper
        presses moved the same way. Built beside the live grid, so the map keeps being published
        meanwhile; ``swap`` installs it. Returns (grid, how many history scans it holds)."""
        g = self.settings.grid
        keys = [_key(t) for t in stamps]
        poses = np.asarray(base_poses, float).reshape(-1, 3)
        kf = sorted((self.history_index[k], i) for i, k in enumerate(keys) if k in self.history_index)
        n = len(self.history)
        grid = self._new_grid()
        if not kf:
            return grid, 0
        kf_stamp = np.array([self.history[h][0] for h, _ in kf])
        kf_odom = np.array([self.history[h][1] for h, _ in kf])
        kf_map = poses[[i for _, i in kf]]
        hist = self.history[:n]
        t = np.array([h[0] for h in hist])
        j = np.clip(np.searchsorted(kf_stamp, t, side="right") - 1, 0, len(kf) - 1)
        base = compose(kf_map[j], between(kf_odom[j], np.array([h[1] for h in hist])))
        sensor = compose(base, np.array([h[2] for h in hist]))
        groups = {}   # one insert_scans call per beam layout (one lidar: one group)
        for i, h in enumerate(hist):
            sc = h[3]
            groups.setdefault((len(sc.ranges), sc.angle_min, sc.angle_increment, sc.range_min, sc.range_max),
                              []).append(i)
        for (_, amin, inc, rmin, rmax), idx in groups.items():
            grid.insert_scans(sensor[idx], np.stack([np.asarray(hist[i][3].ranges, np.float32) for i in idx]),
                              amin, inc, rmin, rmax, no_return_clear_m=g.no_return_clear_m,
                              range_cap_m=g.range_cap_m)
        for p in base:   # the track: a scan every ~5 cm of driving at 5 Hz
            grid.add_visit(p[0], p[1], g.visit_min_speed_mps, g.visit_min_speed_mps)
            self._free_body(grid, p)
        for side, pose, odom in self.bumps:
            if odom is not None:
                k = int(np.argmin(np.hypot(*(kf_odom[:, :2] - np.asarray(odom)[:2]).T)))
                pose = compose(kf_map[k], between(kf_odom[k], odom))
            grid.mark_bumper(pose[0], pose[1], pose[2], BUMPER_ANGLE_RAD[side], self.robot_radius_m, g.bumper_cells)
        self.drawn.update({keys[i]: tuple(poses[i]) for _, i in kf})
        return grid, n

    @staticmethod
    def _covering(g: GridSettings, shape, resolution: float, origin, what: str) -> GridSettings:
        """Grid settings covering a saved grid of ``shape`` (rows, cols) cells at ``origin``."""
        if len(shape) != 2 or 0 in shape:
            raise ValueError(f"{what}: need a non-empty 2-D grid, got shape {tuple(shape)}")
        if not math.isclose(resolution, g.resolution, rel_tol=1e-6):
            raise ValueError(f"{what}: resolution {resolution:g} m differs from the mapper's "
                             f"grid.resolution {g.resolution:g} m")
        rows, cols = shape
        return dataclasses.replace(g, origin_x=float(origin[0]), origin_y=float(origin[1]),
                                   width_m=cols * resolution, height_m=rows * resolution)

    @staticmethod
    def _prior_grid(g: GridSettings, occupancy, resolution: float, origin) -> tuple:
        """(grid settings covering the saved map, its cells' log-odds)."""
        occ = np.asarray(occupancy)
        settings = Mapper._covering(g, occ.shape, resolution, origin, "initial map")
        p = np.clip(occ.astype(np.float32) / 100.0, 1e-3, 1.0 - 1e-3)
        logodds = np.where(occ < 0, np.nan, np.log(p / (1.0 - p))).astype(np.float32)
        return settings, logodds

    def resume_state(self) -> tuple:
        """(log-odds float32 NaN unknown, resolution m, (origin x, y)) of the live grid: what
        ``resume`` takes back (a copy; hold the node's lock while the scans go in)."""
        g = self.grid
        return g.logodds(), g.resolution, (g.origin_x, g.origin_y)

    def _new_grid(self):
        """An empty grid, or one holding the prior map."""
        if self.prior is None:
            return make_grid(self.settings.grid)
        settings, logodds = self.prior
        grid = make_grid(settings)
        grid.set_logodds(logodds)
        return grid

    def swap(self, grid, drawn_scans: int) -> None:
        """Make ``grid`` (from ``redraw``) the live one; the scans inserted while it was drawn
        (history beyond ``drawn_scans``) go into it too, where they were inserted."""
        old, self.grid = self.grid, grid
        self.rerenders += 1
        for h in self.history[drawn_scans:]:
            self._insert(self.grid, h[3], h[4])
        del old

    def bumper(self, side: int, base_pose: tuple, base_odom: tuple | None = None) -> None:
        """A bumper press at ``base_pose``: mark the cells along that bumper occupied. With SLAM,
        ``base_odom`` lets a redraw move the mark with the map."""
        if side not in BUMPER_ANGLE_RAD:
            self.skipped["bad_bumper"] += 1
            return
        self.grid.mark_bumper(base_pose[0], base_pose[1], base_pose[2], BUMPER_ANGLE_RAD[side],
                              self.robot_radius_m, self.settings.grid.bumper_cells)
        self.bumps.append((side, tuple(base_pose), None if base_odom is None else tuple(base_odom)))

    def hold_bump(self, side: int, now_s: float) -> None:
        """A press at sim time ``now_s`` with no base pose yet (TF): a press is rare and precious,
        so it is kept for the next ``motion`` rather than lost."""
        self.held_bumps.append((side, now_s))

    def motion(self, base_pose: tuple, speed_mps: float, now_s: float) -> None:
        """The base at ``base_pose`` (map frame) moving at ``speed_mps``, at sim time ``now_s``:
        a visit, the body's floor free, and the held presses marked there if at most
        BUMP_MAX_AGE_S old (the base has barely moved), else dropped and counted."""
        self.grid.add_visit(base_pose[0], base_pose[1], abs(speed_mps), self.settings.grid.visit_min_speed_mps)
        # The lidar never sees the floor under the body (inside its minimum range): those
        # cells would stay unknown and make a frontier at the robot's own feet (a nearest-
        # frontier explorer then "reaches" it forever). The robot stands there: free.
        self._free_body(self.grid, base_pose)
        for side, pressed in self.held_bumps:
            if 0.0 <= now_s - pressed <= BUMP_MAX_AGE_S:
                self.bumper(side, base_pose)
            else:
                self.skipped["bumper_no_tf"] += 1
        self.held_bumps.clear()

    def _free_body(self, grid, base_pose) -> None:
        ahead, radius = self.body_disc
        grid.free_unknown_disc(base_pose[0] + ahead * math.cos(base_pose[2]),
                               base_pose[1] + ahead * math.sin(base_pose[2]), radius)

    def diagnostics(self) -> str:
        beams = ", ".join(f"{k} {v}" for k, v in sorted(self.beams.items()) if v)
        skipped = ", ".join(f"{k} {v}" for k, v in sorted(self.skipped.items())) or "none"
        kept = sum(v is not None for v in self.drawn.values())
        redrawn = f"; redrawn {self.rerenders} times along {kept} keyframes" if self.drawn else ""
        return (f"{self.scans} scans inserted ({beams}); skipped: {skipped}; "
                f"grid {self.grid.cols}x{self.grid.rows} cells{redrawn}")
