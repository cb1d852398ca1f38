"""Sensor logs a run can be replayed from: CARMEN text logs and rosbags, read into plain records.

The readers yield the same records, oldest first: ``LaserRecord``, ``OdomRecord``,
``ImuRecord`` (rosbag only), ``TagRecord`` (rosbag only) and ``TimeJump`` (rosbag only: time
went back, as when a looping bag was recorded; a consumer clears its state). A line or message
that cannot be used is skipped and counted by reason, never raised out of the iterator; after
the iteration ``summary()`` gives one line for the caller to log. ``LogError`` is raised only
for a file that cannot be read at all.

Here: the records, CARMEN's text, and ``in_stamp_order``, the format-free merge of a bag's
topics into one stream. Bags are read and written by ``turtlebot_recon.ros.bags`` (the ROS
layer: rosbag and the message classes stay out of the core).

CARMEN (http://carmen.sourceforge.net/logger_playback.html and the logger's writer,
``carmen_logwrite_write_robot_laser`` in CARMEN 0.7's ``logger/writelog.c``): one message per
line, ``NAME fields... ipc_timestamp ipc_hostname logger_timestamp``.

- ``ODOM x y theta tv rv accel``
- ``FLASER num_readings [range_readings] x y theta odom_x odom_y odom_theta``: the first pose
  is the laser's, the second the robot's odometry; the beam geometry is not in the line:
  180° from -90° in steps of 180°/n for an even n (180 beams: -90°..+89° in 1° steps) and
  180°/(n - 1) for an odd n (181 beams: -90°..+90°), the steps GMapping's carmen reader uses;
  no maximum range either (``flaser_range_max_m``).
- ``ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
  remission_mode num_readings [range_readings] num_remissions [remissions] laser_pose_x
  laser_pose_y laser_pose_theta robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv
  forward_safety_dist side_safety_dist turn_axis``. The older documentation lists no
  remissions and no turn_axis; both layouts are read (a remission count is an integer token,
  a pose is written with ``%f``).
- ``RAWLASER1``: the same laser header, remissions, no poses (written for a scan without odometry).

Time stamps are the ipc_timestamp (the sender's clock when the message was published), the
standard choice of the tools that read these logs; the logger_timestamp (seconds since the
logger started) is ignored. Lines are in arrival order, which is not always time order: an ODOM
line can be logged after a later laser line. Which order is the robot's is decided by the
odometry, which moves continuously in time order: the records are sorted by time stamp (the
reordered ones counted) unless the odometry's path is shorter in the file's order, as in a log
whose stamps jitter by up to a second (the Intel Research Lab's, 265 stamps going back up to
0.9 s, where sorting them sends the odometry back and forth); the file's order is then kept with
the stamps as written, and said so in the summary. Ranges: a reading at or beyond the maximum
range is CARMEN's "no return" and becomes +inf (REP 117), a reading <= 0 becomes NaN. A laser's
own no-return value, when it is below the format's maximum (the Intel Lab's SICK writes 81.83 m),
is recognised from the data (``no_return_value``: the largest reading, repeated far more often
than any reading near it). Comments (``#``) and other messages (PARAM, SYNC, NMEA...,
ROBOTLASER2) are counted and skipped.
"""
from __future__ import annotations

import dataclasses
import gzip
import heapq
import itertools
import math
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Collection, Iterable, Iterator, List, Optional, Tuple, Union

import numpy as np

FLASER_RANGE_MAX_M = 81.9     # SICK LMS (the FLASER datasets' laser): 8191 cm is "no return"
MESSAGE_NAME = re.compile(r"[A-Z][A-Z0-9_]*$")
MAX_BEAMS = 100_000           # a count above this is a corrupted field, not a laser
NO_RETURN_MIN_READINGS = 20   # a laser's largest reading is its "no return" code when it occurs
                              # at least this often ...
NO_RETURN_SPIKE_RATIO = 10.0  # ... and this many times more often than any other value within
NO_RETURN_NEAR = 0.9          # this fraction below it (a real return: a spread of values)

Pose = Tuple[float, float, float]


class LogError(ValueError):
    """The file cannot be read as a log at all (missing, not a bag, no scan topic)."""


@dataclass(frozen=True, eq=False)
class LaserRecord:
    """One scan; angles in the laser's frame, counter-clockwise, ranges (m) as float32."""
    stamp_s: float
    ranges: np.ndarray
    angle_min: float                   # rad, bearing of ranges[0]
    angle_increment: float             # rad
    range_min: float                   # m
    range_max: float                   # m
    odom_pose: Optional[Pose] = None   # the robot's (x, y, yaw) in odom at stamp_s (CARMEN)
    laser_pose: Optional[Pose] = None  # the laser's (x, y, yaw) in odom at stamp_s (CARMEN)


@dataclass(frozen=True)
class OdomRecord:
    stamp_s: float
    x: float        # m, odom frame
    y: float
    yaw: float      # rad
    v: float        # m/s, forward
    w: float        # rad/s


@dataclass(frozen=True)
class ImuRecord:
    stamp_s: float
    yaw_rate: float   # rad/s, angular_velocity.z


@dataclass(frozen=True)
class TagRecord:
    stamp_s: float
    msg: Any          # turtlebot_recon/TagDetectionArray as read from the bag


@dataclass(frozen=True)
class TimeJump:
    """Time went back from ``previous_s`` to ``stamp_s``: what follows is a new run."""
    stamp_s: float
    previous_s: float


Record = Union[LaserRecord, OdomRecord, ImuRecord, TagRecord, TimeJump]


class LogStats:
    """What a reader kept and skipped; the first example of each problem is kept for the log."""

    def __init__(self, source: str):
        self.source = source
        self.kept: Counter = Counter()       # record kind -> count
        self.skipped: Counter = Counter()    # reason -> count (data lost)
        self.ignored: Counter = Counter()    # comment / message name / topic -> count (by design)
        self.first: dict = {}                # reason -> "where: what"
        self.reordered = 0
        self.file_order_kept = ""            # why the file's order was kept over the stamps'
        self.no_return: dict = {}            # laser (beams) -> (its no-return value m, readings)
        self.jumps: List[TimeJump] = []

    def skip(self, reason: str, where: str, detail: str) -> None:
        self.skipped[reason] += 1
        self.first.setdefault(reason, f"{where}: {detail}")

    def summary(self) -> str:
        kept = ", ".join(f"{n} {k}" for k, n in sorted(self.kept.items())) or "no records"
        parts = [f"{self.source}: {kept}"]
        if self.skipped:
            parts.append(f"skipped {sum(self.skipped.values())}: " + ", ".join(
                f"{n} {r} (first {self.first[r]})" for r, n in sorted(self.skipped.items())))
        if self.ignored:
            parts.append("ignored " + ", ".join(f"{n} {k}" for k, n in sorted(self.ignored.items())))
        for beams, (value, count) in sorted(self.no_return.items()):
            parts.append(f"no return at {value:.2f} m on the {beams}-beam laser (from the data: {count} readings)")
        if self.file_order_kept:
            parts.append(self.file_order_kept)
        elif self.reordered:
            parts.append(f"{self.reordered} out of time order (sorted)")
        if self.jumps:
            j = self.jumps[0]
            parts.append(f"time went back {len(self.jumps)} time(s) (first from {j.previous_s:.3f} s "
                         f"to {j.stamp_s:.3f} s)")
        return "; ".join(parts)


# ------------------------------------------------------------------------------------ CARMEN
class _BadLine(Exception):
    def __init__(self, reason: str, detail: str):
        super().__init__(detail)
        self.reason = reason


def _float(tok: str, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise _BadLine("malformed", f"{what} {tok[:20]!r} is not a number") from None
    if not math.isfinite(v):
        raise _BadLine("malformed", f"{what} is {tok}")
    return v


def _count(tok: str, what: str) -> int:
    if not tok.isdigit() or int(tok) > MAX_BEAMS:
        raise _BadLine("malformed", f"{what} {tok[:20]!r} is not a count")
    return int(tok)


def _need(tokens: list, n: int, name: str) -> None:
    if len(tokens) < n:
        raise _BadLine("truncated", f"{name} needs {n} fields, has {len(tokens)}")
    if len(tokens) > n:
        raise _BadLine("malformed", f"{name} has {len(tokens) - n} fields too many")


def _pose(tokens: list, what: str) -> Pose:
    x, y, yaw = (_float(t, what) for t in tokens)
    return (x, y, yaw)


def _ranges(tokens: list, range_max: float) -> np.ndarray:
    try:
        r = np.array(tokens, dtype=np.float64)
    except ValueError:
        raise _BadLine("malformed", "a range reading is not a number") from None
    r = np.where(r >= range_max, np.inf, r)        # CARMEN's "no return" -> REP 117 +inf
    return np.where(r > 0.0, r, np.nan).astype(np.float32)


def no_return_value(readings) -> Optional[float]:
    """A laser's own "no return" reading (m) recognised in its readings (any shape, all the
    scans of one laser), or None: the largest finite reading when it occurs at least
    NO_RETURN_MIN_READINGS times and NO_RETURN_SPIKE_RATIO times more often than any other single
    value within NO_RETURN_NEAR of it. A return's range is spread over many values (a wall seen
    from a moving robot); a code the laser writes when nothing came back is one value, repeated
    on every beam that saw nothing, and above all the real ones."""
    r = np.asarray(readings, np.float32).ravel()
    with np.errstate(invalid="ignore"):
        r = r[np.isfinite(r) & (r > 0.0)]
    if r.size == 0:
        return None
    top = r.max()
    at_top = int(np.count_nonzero(r == top))
    near = r[(r >= NO_RETURN_NEAR * top) & (r < top)]
    runner_up = int(np.unique(near, return_counts=True)[1].max()) if near.size else 0
    if at_top < NO_RETURN_MIN_READINGS or at_top < NO_RETURN_SPIKE_RATIO * runner_up:
        return None
    return float(top)


def _odometry_path_m(records: list) -> float:
    """The length (m) of the path the odometry poses of ``records`` trace in their order."""
    xy = np.array([(r.x, r.y) if isinstance(r, OdomRecord) else r.odom_pose[:2] for r in records
                   if isinstance(r, OdomRecord) or getattr(r, "odom_pose", None) is not None], float)
    return float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0


def flaser_geometry(n: int) -> Tuple[float, float]:
    """(angle_min, angle_increment) rad of an n-beam FLASER scan: 180° from -90°."""
    return -0.5 * math.pi, math.pi / (n - 1 if n % 2 else n)


class CarmenReader:
    """Records of a CARMEN log (``.gz`` read as gzip), sorted by ipc_timestamp.

    ``range_min_m``: the logs do not carry it; ``flaser_range_max_m``: nor, for FLASER, this."""

    def __init__(self, path: Union[str, Path], range_min_m: float = 0.0,
                 flaser_range_max_m: float = FLASER_RANGE_MAX_M):
        self.path = Path(path)
        if not self.path.is_file():
            raise LogError(f"{self.path}: no such file")
        self.range_min_m = range_min_m
        self.flaser_range_max_m = flaser_range_max_m
        self.stats = LogStats(self.path.name)

    def summary(self) -> str:
        return self.stats.summary()

    def __iter__(self) -> Iterator[Record]:
        self.stats = LogStats(self.path.name)
        records, newest = [], -math.inf
        opener = gzip.open if self.path.suffix == ".gz" else open
        try:
            with opener(self.path, "rt", encoding="utf-8", errors="replace") as f:
                for lineno, line in enumerate(f, 1):
                    rec = self._line(line, lineno)
                    if rec is not None:
                        self.stats.reordered += rec.stamp_s < newest
                        newest = max(newest, rec.stamp_s)
                        records.append(rec)
        except (OSError, EOFError) as e:   # a gzip cut short: keep what was read
            self.stats.skip("unreadable", "file", str(e))
        records = self._time_order(records)
        records = self._no_return(records)
        for rec in records:
            self.stats.kept[type(rec).__name__] += 1
            yield rec

    def _time_order(self, records: list) -> list:
        """The records sorted by stamp (stable), unless the odometry's path is shorter in the
        file's order (see the module doc)."""
        by_stamp = sorted(records, key=lambda r: r.stamp_s)
        if self.stats.reordered:
            in_file, in_stamps = _odometry_path_m(records), _odometry_path_m(by_stamp)
            if in_file < in_stamps:
                self.stats.file_order_kept = (
                    f"{self.stats.reordered} stamps out of order: the file's order kept (the odometry travels "
                    f"{in_file:.1f} m in it, {in_stamps:.1f} m in stamp order)")
                return records
        return by_stamp

    def _no_return(self, records: list) -> list:
        """Each laser's readings at or above its own no-return value (``no_return_value``) made
        +inf, its range_max that value."""
        lasers: dict = {}
        for i, r in enumerate(records):
            if isinstance(r, LaserRecord):
                lasers.setdefault((len(r.ranges), r.angle_min, r.angle_increment), []).append(i)
        for (beams, _, _), idx in lasers.items():
            value = no_return_value(np.stack([records[i].ranges for i in idx]))
            if value is None:
                continue
            count = 0
            for i in idx:
                r = records[i]
                with np.errstate(invalid="ignore"):
                    none = r.ranges >= np.float32(value)
                count += int(np.count_nonzero(none))
                records[i] = dataclasses.replace(r, ranges=np.where(none, np.float32(np.inf), r.ranges),
                                                 range_max=min(r.range_max, value))
            self.stats.no_return[beams] = (value, count)
        return records

    def _line(self, line: str, lineno: int) -> Optional[Record]:
        tokens = line.split()
        if not tokens:
            return None
        name = tokens[0]
        if name.startswith("#"):
            self.stats.ignored["comment"] += 1
            return None
        parse = {"ODOM": self._odom, "FLASER": self._flaser, "ROBOTLASER1": self._robotlaser,
                 "RAWLASER1": self._robotlaser}.get(name)
        if parse is None:
            if MESSAGE_NAME.match(name):
                self.stats.ignored[name] += 1
            else:
                self.stats.skip("malformed", f"line {lineno}", f"{name[:20]!r} is not a message name")
            return None
        try:
            return parse(tokens)
        except _BadLine as e:
            self.stats.skip(e.reason, f"line {lineno}", str(e))
            return None

    def _odom(self, t: list) -> OdomRecord:
        _need(t, 10, "ODOM")
        x, y, yaw, v, w = (_float(tok, "ODOM field") for tok in t[1:6])
        return OdomRecord(_float(t[7], "ipc_timestamp"), x, y, yaw, v, w)

    def _flaser(self, t: list) -> LaserRecord:
        n = _count(t[1], "num_readings") if len(t) > 1 else 0
        _need(t, 2 + n + 9, "FLASER")
        if n < 2:
            raise _BadLine("malformed", f"FLASER with {n} readings")
        angle_min, inc = flaser_geometry(n)
        rest = t[2 + n:]
        return LaserRecord(_float(rest[6], "ipc_timestamp"), _ranges(t[2:2 + n], self.flaser_range_max_m),
                           angle_min, inc, self.range_min_m, self.flaser_range_max_m,
                           odom_pose=_pose(rest[3:6], "odom pose"), laser_pose=_pose(rest[0:3], "laser pose"))

    def _robotlaser(self, t: list) -> LaserRecord:
        name = t[0]
        if len(t) < 10:
            raise _BadLine("truncated", f"{name} needs at least 10 fields, has {len(t)}")
        start, _fov, inc, range_max = (_float(tok, f"{name} header") for tok in t[2:6])
        if inc == 0.0 or range_max <= 0.0:
            raise _BadLine("malformed", f"{name} angular_resolution {inc}, maximum_range {range_max}")
        n = _count(t[8], "num_readings")
        rest = t[9 + n:]
        if len(rest) < 4:
            raise _BadLine("truncated", f"{name} declares {n} readings, has {max(len(t) - 9, 0)}")
        # Where the poses start: after num_remissions and the remissions (CARMEN 0.7: an
        # integer token), or right after the ranges (the older layout).
        layouts = [1 + int(rest[0])] if rest[0].isdigit() and int(rest[0]) <= MAX_BEAMS else []
        if name == "RAWLASER1":
            if not layouts:
                raise _BadLine("malformed", f"{name} num_remissions {rest[0][:20]!r} is not a count")
            _need(rest, layouts[0] + 3, name)
            odom = laser = None
        else:
            tails = [len(rest) - at for at in layouts + [0]]   # 13 fields without turn_axis, 14 with
            fits = [at for at, tail in zip(layouts + [0], tails) if 13 <= tail <= 14]
            if not fits:
                if tails[0] < 13:
                    raise _BadLine("truncated", f"{name} ends {13 - tails[0]} fields short")
                raise _BadLine("malformed", f"{name} has {tails[0] - 14} fields too many")
            at = fits[0]
            laser = _pose(rest[at:at + 3], "laser pose")
            odom = _pose(rest[at + 3:at + 6], "robot pose")
        return LaserRecord(_float(rest[-3], "ipc_timestamp"), _ranges(t[9:9 + n], range_max),
                           start, inc, self.range_min_m, range_max, odom_pose=odom, laser_pose=laser)


def _f(v: float) -> str:
    return repr(float(v))   # shortest text that reads back to the same double


def _carmen_ranges(rec: LaserRecord) -> str:
    """Ranges as the shortest float32 text; invalid ones as maximum_range (CARMEN's no return),
    a valid one at maximum_range just below it."""
    r = np.asarray(rec.ranges, dtype=np.float32)
    below = np.float32(rec.range_max)
    while float(below) >= rec.range_max:
        below = np.nextafter(below, np.float32(0.0))
    r64 = r.astype(np.float64)          # compared in double, as the reader will
    valid = np.isfinite(r64) & (r64 >= rec.range_min) & (r64 <= rec.range_max) & (r64 > 0.0)
    none = _f(rec.range_max)
    return " ".join(str(v) if ok else none for v, ok in zip(np.minimum(r, below), valid))


def write_carmen(path: Union[str, Path], records: Iterable[Record], host: str = "turtlebot_recon",
                 flaser: bool = False) -> int:
    """Write LaserRecords (ROBOTLASER1; RAWLASER1 without an odom pose; FLASER with
    ``flaser`` for a 180-beam scan of FLASER's geometry) and OdomRecords; returns the lines
    written. Read back by ``CarmenReader``: equal but for invalid ranges, which come back as
    +inf, and range_min (and a FLASER's range_max), which the format does not carry.
    TypeError for any other record."""
    lines = ["# CARMEN Logfile", "# file format is one message per line",
             "# message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp",
             "# ODOM x y theta tv rv accel",
             "# FLASER num_readings [range_readings] x y theta odom_x odom_y odom_theta",
             "# RAWLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy "
             "remission_mode num_readings [range_readings] num_remissions [remission values]",
             "# ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy "
             "remission_mode num_readings [range_readings] num_remissions [remission values] laser_pose_x "
             "laser_pose_y laser_pose_theta robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv "
             "forward_safety_dist side_safty_dist turn_axis",
             "# written by turtlebot_recon: ipc_timestamp = the record's stamp (s)"]
    t0 = None
    count = 0
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
        for rec in records:
            t0 = rec.stamp_s if t0 is None else t0
            stamps = f"{_f(rec.stamp_s)} {host} {rec.stamp_s - t0:.6f}"
            if isinstance(rec, OdomRecord):
                f.write(f"ODOM {_f(rec.x)} {_f(rec.y)} {_f(rec.yaw)} {_f(rec.v)} {_f(rec.w)} 0.0 {stamps}\n")
            elif isinstance(rec, LaserRecord):
                f.write(_laser_line(rec, flaser) + f" {stamps}\n")
            else:
                raise TypeError(f"write_carmen: no CARMEN message for {type(rec).__name__}")
            count += 1
    return count


def _laser_line(rec: LaserRecord, flaser: bool) -> str:
    n = len(rec.ranges)
    odom, laser = rec.odom_pose, rec.laser_pose or rec.odom_pose
    if flaser and odom is not None and n == 180 and np.allclose(
            (rec.angle_min, rec.angle_increment), flaser_geometry(n), atol=1e-9):
        return f"FLASER {n} {_carmen_ranges(rec)} " + " ".join(_f(v) for v in (*laser, *odom))
    fov = (n - 1) * rec.angle_increment
    head = (f"0 {_f(rec.angle_min)} {_f(fov)} {_f(rec.angle_increment)} {_f(rec.range_max)} 0.0 0 "
            f"{n} {_carmen_ranges(rec)} 0")   # laser_type (not read), ..., no remissions
    if odom is None:
        return f"RAWLASER1 {head}"
    return f"ROBOTLASER1 {head} " + " ".join(_f(v) for v in (*laser, *odom)) + " 0.0 0.0 0.0 0.0 0.0"


# ------------------------------------------------------------------------------------ merging streams
def in_stamp_order(records: Iterable[Tuple[str, Record]], continuous: Collection[str], stats: LogStats,
                   max_lag_s: float = 5.0, jump_back_s: float = 1.0) -> Iterator[Record]:
    """(stream, record) pairs in recording order (a bag's topics) merged into stamp order.

    Each stream's own stamps only go forward, but one stream can reach the recorder seconds
    after another (rosbag record's per-topic queues under load, a simulation running faster
    than real time): a record is given once every ``continuous`` stream (all but the tags) has
    passed its stamp, or once it is ``max_lag_s`` older than the newest stamp (a stream that fell
    silent). A stream's stamp more than ``jump_back_s`` older than its own previous one is a
    jump back (a looping bag): the first stream to jump flushes the buffer and yields a
    TimeJump; the others' records from before their own jump are then skipped as "before the
    jump". A record older than its stream's previous within ``jump_back_s``, or older than one
    already given, is late and skipped. Skips, reorderings and jumps are counted in ``stats``."""
    heap: list = []
    seq = itertools.count()
    epoch = 0                    # time jumps so far
    last: dict = {}              # stream -> (its epoch, its newest stamp)
    newest, last_out = -math.inf, -math.inf

    def watermark() -> float:
        """The stamp every continuous stream has passed in this epoch (-inf while one has not
        spoken in it yet)."""
        return min((last[t][1] if t in last and last[t][0] == epoch else -math.inf for t in continuous),
                   default=-math.inf)

    for stream, rec in records:
        s = rec.stamp_s
        stream_epoch, previous = last.get(stream, (epoch, -math.inf))
        if s < previous - jump_back_s:               # this stream's time went back
            if stream_epoch < epoch:                  # another stream's jump started the new run
                stream_epoch = epoch
            else:
                while heap:
                    yield heapq.heappop(heap)[2]
                jump = TimeJump(s, newest)
                stats.jumps.append(jump)
                yield jump
                epoch += 1
                stream_epoch = epoch
                newest, last_out = s, -math.inf
            previous = -math.inf
        elif stream_epoch < epoch:
            stats.skip("before the jump", f"{type(rec).__name__} at {s:.3f} s",
                       "recorded after the time jump, stamped before it")
            continue
        if s < previous or s < last_out:
            stats.skip("late", f"{type(rec).__name__} at {s:.3f} s",
                       f"{max(previous, last_out) - s:.3f} s older than one before it")
            continue
        last[stream] = (stream_epoch, s)
        stats.reordered += s < newest
        newest = max(newest, s)
        heapq.heappush(heap, (s, next(seq), rec))
        ready = max(watermark(), newest - max_lag_s)
        while heap and heap[0][0] <= ready:
            last_out = heap[0][0]
            yield heapq.heappop(heap)[2]
    while heap:
        yield heapq.heappop(heap)[2]
