"""Recovery geometry and the stuck watchdog: pure functions of plain data, no clock of their own.

Frames and signs: poses are (x, y, yaw) in the map frame (m, rad); bearings are in the robot
frame, 0 straight ahead, positive to the left (REP-103: +yaw is counter-clockwise).

- ``ring_candidates`` / ``choose_nudge``: seed 004's recovery nudge. Candidate points lie on
  rings around the robot (0.3 / 0.6 / 0.9 m) at evenly spaced bearings. A point is usable
  when it and every inner ring point on the same bearing are free (so the straight drive out
  crosses no obstacle the costmap knows) and the latest scan sees no return before it. The
  seed sends the first safe point; we score them: reach + openness (scan clearance, capped) +
  a bonus for heading back the way the robot came (known free space).
- ``turn_away_rad``: seed 001's bumper recovery turn: 15 deg away from a side hit, 45 deg on a
  centre hit. The seed picks the centre-hit direction at random; we turn to the side the scan
  shows more open (left without a scan), which is deterministic and better informed.
- ``obstacle_side``: which "bumper" a stuck robot without a bumper press should act as if
  hit, from the scan: the side with less clearance.
- ``most_open_bearing``: seed 001's drift out of a local minimum. The seed drifts along its
  last angular command; we drift toward the most open direction of the latest scan, where a
  direction counts only if its neighbours are open too (a one-ray gap is no way out).
- ``StuckWatchdog``: seed 004's watchdog, "moved < 0.3 m in 10 s".
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple

from ..geometry import wrap_angle

Pose = Tuple[float, float, float]
FreeSpace = Callable[[float, float], bool]        # (x, y) map frame -> free and clear for the robot
Clearance = Callable[[float], float]              # robot-frame bearing (rad) -> free distance (m)

LEFT, CENTRE, RIGHT = 0, 1, 2                      # kobuki BumperEvent.bumper values


def bearings(count: int) -> list:
    """``count`` evenly spaced robot-frame bearings starting straight ahead, in [-pi, pi)."""
    return [wrap_angle(2.0 * math.pi * k / count) for k in range(count)]


# ------------------------------------------------------------------------------ nudge

@dataclass(frozen=True)
class Candidate:
    x: float                # map frame, m
    y: float
    bearing_rad: float      # robot frame
    radius_m: float         # distance from the robot
    score_m: float = 0.0    # choose_nudge's score (higher is better)

    def goal(self, pose: Pose) -> Pose:
        """The nudge goal: the point, facing the way the robot drives to it."""
        return (self.x, self.y, wrap_angle(pose[2] + self.bearing_rad))


def ring_candidates(pose: Pose, radii_m: Sequence[float], count: int) -> list:
    """Points on each ring (inner first) at ``count`` bearings around ``pose``, map frame."""
    x, y, yaw = pose
    out = []
    for r in radii_m:
        for b in bearings(count):
            out.append(Candidate(x + r * math.cos(yaw + b), y + r * math.sin(yaw + b), b, r))
    return out


def choose_nudge(pose: Pose, radii_m: Sequence[float], count: int, free_space: FreeSpace,
                 clearance: Optional[Clearance] = None, back_bearing_rad: Optional[float] = None,
                 clearance_cap_m: float = 1.0, back_bonus_m: float = 0.5) -> Optional[Candidate]:
    """The best nudge point around ``pose``, or None when no ring point is usable.

    Per bearing b, the reach is the largest ring radius r such that every ring point on b
    up to r is free and the scan (if any) sees at least r of free space along b. Its score is
        reach_m + min(clearance(b), clearance_cap_m) + back_bonus_m * cos(b - back_bearing)
    (the last two terms only when a scan / a way back is known). Ties keep the first bearing
    in ``bearings(count)`` order (straight ahead first).
    """
    radii = sorted(radii_m)
    by_bearing = {}
    for c in ring_candidates(pose, radii, count):
        by_bearing.setdefault(c.bearing_rad, []).append(c)
    best: Optional[Candidate] = None
    for b, ring in by_bearing.items():
        open_m = clearance(b) if clearance is not None else math.inf
        reach: Optional[Candidate] = None
        for c in ring:                       # inner to outer; stop at the first blocked point
            if c.radius_m > open_m or not free_space(c.x, c.y):
                break
            reach = c
        if reach is None:
            continue
        score = reach.radius_m
        if clearance is not None:
            score += min(open_m, clearance_cap_m)
        if back_bearing_rad is not None:
            score += back_bonus_m * math.cos(b - back_bearing_rad)
        if best is None or score > best.score_m:
            best = Candidate(reach.x, reach.y, b, reach.radius_m, score)
    return best


# ----------------------------------------------------------------------- bumper turn

def more_open_side(clearance: Optional[Clearance], side_bearing_rad: float) -> int:
    """+1 if the scan shows more room to the left (at +side_bearing) than to the right, else -1;
    +1 without a scan or on a tie."""
    if clearance is None:
        return 1
    return 1 if clearance(side_bearing_rad) >= clearance(-side_bearing_rad) else -1


def obstacle_side(clearance: Optional[Clearance], side_bearing_rad: float) -> int:
    """LEFT / RIGHT: the side whose scan clearance is smaller; CENTRE on a tie or without a scan."""
    if clearance is None:
        return CENTRE
    left, right = clearance(side_bearing_rad), clearance(-side_bearing_rad)
    if left < right:
        return LEFT
    if right < left:
        return RIGHT
    return CENTRE


def turn_away_rad(side: int, side_turn_rad: float, centre_turn_rad: float,
                  centre_sign: int = 1) -> float:
    """Signed in-place turn after backing off from a hit on ``side`` (REP-103, + = left).

    Left hit -> turn right (-side_turn); right hit -> turn left (+side_turn);
    centre hit -> centre_sign * centre_turn (centre_sign from ``more_open_side``).
    """
    if side == LEFT:
        return -side_turn_rad
    if side == RIGHT:
        return side_turn_rad
    if side == CENTRE:
        return math.copysign(centre_turn_rad, centre_sign)
    raise ValueError(f"bumper side must be 0 (left), 1 (centre) or 2 (right), got {side!r}")


# ----------------------------------------------------------------------------- drift

def most_open_bearing(clearance: Clearance, count: int, half_window: int = 1) -> Tuple[float, float]:
    """(bearing_rad, clearance_m) of the most open direction among ``bearings(count)``.

    A bearing's openness is the smallest clearance over it and its ``half_window`` neighbours
    each side (cyclic). Ties go to the bearing closest to straight ahead.
    """
    bs = bearings(count)
    raw = [clearance(b) for b in bs]
    best_b, best_open = 0.0, -math.inf
    for k, b in enumerate(bs):
        open_m = min(raw[(k + j) % count] for j in range(-half_window, half_window + 1))
        if open_m > best_open or (open_m == best_open and abs(b) < abs(best_b)):
            best_b, best_open = b, open_m
    return best_b, best_open


# -------------------------------------------------------------------------- watchdog

class StuckWatchdog:
    """Seed 004's watchdog: stuck when the robot stays within ``distance_m`` of an anchor point
    for ``window_s`` of time in which it should be moving.

    The anchor is the pose where the robot last made progress (got ``distance_m`` from the
    previous anchor), or where ``reset`` put it. The time between two ticks counts when either
    of them expected motion (``moving``); stretches with none do not (waiting for a goal), but
    they do not move the anchor either, so a robot that keeps getting goals it "reaches" where
    it stands (the navigator active for a tick, then done, again and again) is stuck after
    ``window_s`` like one that cannot move. ``update`` returns "progress" when the robot
    reaches ``distance_m`` (>=) from the anchor, "stuck" on a tick that expects motion once
    ``window_s`` (>=) have counted without that, and None otherwise. After "stuck" the window
    starts again, so it fires at most once per window.
    """

    def __init__(self, distance_m: float, window_s: float):
        self.distance_m = distance_m
        self.window_s = window_s
        self._anchor: Optional[Tuple[float, float]] = None
        self._counted_s = 0.0
        self._last: Optional[Tuple[float, bool]] = None     # (time, moving) of the last tick

    def reset(self, xy: Sequence[float], now_s: float, moving: bool = False) -> None:
        """Anchor at ``xy``, nothing counted; ``moving``: whether this tick expected motion."""
        self._anchor, self._counted_s = (float(xy[0]), float(xy[1])), 0.0
        self._last = (now_s, moving)

    def update(self, xy: Sequence[float], now_s: float, moving: bool) -> Optional[str]:
        last, self._last = self._last, (now_s, moving)
        if self._anchor is None:
            self.reset(xy, now_s, moving)
            return None
        if last is not None and (moving or last[1]):
            self._counted_s += max(0.0, now_s - last[0])
        if math.dist(xy[:2], self._anchor) >= self.distance_m:
            self.reset(xy, now_s, moving)
            return "progress"
        if moving and self._counted_s >= self.window_s:
            self.reset(xy, now_s, moving)
            return "stuck"
        return None
