"""What the mapper notices about its inputs, said once per episode (docs/faults.md, streams):

- scans lost: their stamps further apart than the lidar's own ``scan_time`` says, measured over
  SCAN_LOSS_WINDOW_S of stamps; a share missing above SCAN_LOSS_SAY is an episode;
- TF late: scans skipped because the transform at their stamp had not come yet
  (``scan_tf_extrapolation``) with the newest transform this far behind the clock; TF_LATE_SKIPS
  of them within TF_LATE_WINDOW_S make an episode;
and the clock jumping back is said by the node at each jump (``Mapper.time_jumped_back``).

An episode is said once, when it begins; a loss episode ends with a measurement under half
SCAN_LOSS_SAY (a steady 20 % loss dips under 10 % in one window of 20, under 5 % in one of
1,000), a TF one after EPISODE_QUIET_S (sim) without a late transform; the next one is said
again, at most one line per kind every LINE_MIN_GAP_S. ROS-free: the
node passes times (s) and gets back the line to log, or None.
"""
from __future__ import annotations

import math

SCAN_LOSS_WINDOW_S = 10.0   # sim s of scan stamps per measurement
SCAN_LOSS_SAY = 0.10        # a share of scans missing above this is said (a fault-free run: 0)
TF_LATE_SKIPS = 10          # scans skipped for a late TF within TF_LATE_WINDOW_S: an episode (a
                            # fifth of a 5 Hz lidar's; fault-free on a loaded machine: 7 in 240 s)
TF_LATE_WINDOW_S = 10.0     # sim s
EPISODE_QUIET_S = 10.0      # sim s without a late transform end a TF episode
LINE_MIN_GAP_S = 30.0       # sim s between two lines of one kind


class _Episode:
    """One kind of fault: its start said once; ``end``, or ``quiet_s`` without a sign, ends it."""

    def __init__(self, quiet_s: float):
        self.quiet_s = quiet_s
        self.last_seen_s = -math.inf      # the fault's last sign
        self.said_s = -math.inf           # when its line was last said
        self.open = False

    def seen(self, now_s: float) -> bool:
        """The fault seen at ``now_s``: True when a line is due (a new episode, not throttled)."""
        if self.open and now_s - self.last_seen_s > self.quiet_s:
            self.open = False
        self.last_seen_s = now_s
        if self.open or now_s - self.said_s < LINE_MIN_GAP_S:
            self.open = True
            return False
        self.open, self.said_s = True, now_s
        return True

    def end(self) -> None:
        self.open = False


class StreamWatch:
    """The mapper's watch over ``topic`` (the scans) and its TF (module docstring)."""

    def __init__(self, topic: str, who: str = "mapper"):
        self.topic, self.who = topic, who
        self.window_from_s = None      # first scan stamp of the current measurement
        self.last_stamp_s = None
        self.received = 0              # scans in the window after its first
        self.missing = 0               # scans the stamps' gaps say were lost, in the window
        self.late = []                 # sim times of scans skipped for a late TF, in the window
        self.episodes = {"loss": _Episode(math.inf), "tf": _Episode(EPISODE_QUIET_S)}

    def scan(self, stamp_s: float, scan_time_s: float) -> str | None:
        """A scan stamped ``stamp_s`` from a lidar that sends one every ``scan_time_s`` (its
        LaserScan.scan_time; 0 = unknown: not measured)."""
        if not (scan_time_s > 0 and math.isfinite(scan_time_s) and math.isfinite(stamp_s)):
            return None
        if self.last_stamp_s is None or stamp_s <= self.last_stamp_s:   # the first, or time went back
            self.window_from_s, self.last_stamp_s, self.received, self.missing = stamp_s, stamp_s, 0, 0
            return None
        self.missing += max(0, round((stamp_s - self.last_stamp_s) / scan_time_s) - 1)
        self.received += 1
        self.last_stamp_s = stamp_s
        span = stamp_s - self.window_from_s
        if span < SCAN_LOSS_WINDOW_S:
            return None
        expected = self.received + self.missing
        lost = self.missing / expected
        self.window_from_s, self.received, self.missing = stamp_s, 0, 0
        if lost < SCAN_LOSS_SAY / 2:
            self.episodes["loss"].end()
        if lost <= SCAN_LOSS_SAY or not self.episodes["loss"].seen(stamp_s):
            return None
        return (f"{self.who}: {100 * lost:.0f} % of the scans on {self.topic} missing over the last {span:.0f} s "
                f"({expected - round(lost * expected)} of {expected} at the lidar's {1 / scan_time_s:.1f} Hz): "
                f"lost on the way or dropped while the {self.who} was busy; the map grows from the rest")

    def tf_late(self, now_s: float, stamp_s: float, latest_tf_s: float, frames: str, waited_s: float) -> str | None:
        """A scan stamped ``stamp_s`` skipped at ``now_s`` because the transform ``frames``
        was only known up to ``latest_tf_s`` after waiting ``waited_s``."""
        if not (math.isfinite(latest_tf_s) and stamp_s > latest_tf_s):
            return None            # not a late TF (a scan older than the buffer)
        self.late = [t for t in self.late if now_s - t <= TF_LATE_WINDOW_S] + [now_s]
        if len(self.late) < TF_LATE_SKIPS or not self.episodes["tf"].seen(now_s):
            return None
        return (f"{self.who}: TF {frames} lags the scans: its newest transform is {now_s - latest_tf_s:.2f} s behind "
                f"the clock, more than the {waited_s:.2f} s a scan waits for it (tf_timeout_s); {len(self.late)} "
                f"scans skipped in the last {TF_LATE_WINDOW_S:.0f} s (scan_tf_extrapolation)")

    def restart(self) -> None:
        """The clock jumped back (``Mapper.time_jumped_back``): the scans' stamps start again."""
        self.window_from_s = self.last_stamp_s = None
        self.late.clear()
