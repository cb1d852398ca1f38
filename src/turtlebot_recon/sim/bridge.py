"""What the sim_bridge node decides, apart from ROS: how fast the simulation runs against the
wall clock, when at rtf 0 it waits for the controller's next command, where its wall time goes,
the robot's outline for rviz and the true path relative to the start pose. The node supplies
the clocks and the waiting."""
from __future__ import annotations

import math
from collections import defaultdict
from typing import Optional

from ..geometry import wrap_angle
from ..robot import RobotSpec

FAR_BEHIND_S = 1.0   # wall s: a pacer this far behind (a slow machine) starts afresh


class Pacer:
    """Holds sim time to ``rtf`` times wall time (rtf 0: as fast as possible, never sleeps).
    Far behind, it does not sprint to catch up: it counts again from where it is."""

    def __init__(self, rtf: float, sim_s: float, wall_s: float):
        self.rtf = rtf
        self._sim0, self._wall0 = sim_s, wall_s

    def sleep_s(self, sim_s: float, wall_s: float) -> float:
        """Wall seconds to sleep so that sim time ``sim_s`` is reached no sooner than rtf allows."""
        if self.rtf <= 0:
            return 0.0
        ahead = (sim_s - self._sim0) / self.rtf - (wall_s - self._wall0)
        if ahead < -FAR_BEHIND_S:
            self._sim0, self._wall0 = sim_s, wall_s
        return max(ahead, 0.0)


class StartupPace:
    """rtf 0: real time until the base's first command, for at most ``max_wall_s`` of wall time.
    The stack starts in wall time (a few seconds); stepped as fast as possible meanwhile, ~45 s
    of sim time passed before the explorer's first command, the robot standing and its
    odometry's heading drifting with the gyro's bias, and SLAM anchored the map at the heading
    its first keyframe found (a house's whole map turned by 2-4 mrad). A run that never
    commands the base steps at full speed once ``max_wall_s`` has passed."""

    def __init__(self, rtf: float, max_wall_s: float, sim_s: float, wall_s: float):
        self.on = rtf <= 0 and max_wall_s > 0
        self._pacer = Pacer(1.0, sim_s, wall_s)
        self._until_s = wall_s + max_wall_s

    def commanded(self) -> None:
        self.on = False

    def sleep_s(self, sim_s: float, wall_s: float) -> float:
        """Wall seconds to sleep so that sim time runs no faster than wall time while it is on."""
        if self.on and wall_s >= self._until_s:
            self.on = False
        return self._pacer.sleep_s(sim_s, wall_s) if self.on else 0.0


class CommandSync:
    """rtf 0: the simulation outruns a controller starved of CPU, and the base would drive on
    its last command for up to cmd_timeout_s. While the base moves, once the last command is
    ``age_s`` old (sim time), the bridge waits for the next one (at most ``wait_s`` of wall
    time; after a wait runs out, not again until a command comes)."""

    def __init__(self, rtf: float, age_s: float, wait_s: float):
        self.on = rtf <= 0 and age_s > 0
        self.age_s, self.wait_s = age_s, wait_s
        self._last_s = 0.0          # sim time of the last applied command
        self._waits = True

    def applied(self, now_s: float) -> None:
        self._last_s, self._waits = now_s, True

    def gave_up(self) -> None:
        """A wait ran out: the publisher may have stopped, so no more waits until a command comes."""
        self._waits = False

    def wait_for_s(self, now_s: float, v_mps: float, w_radps: float) -> float:
        """Wall seconds to wait for the next command before this step (0: step now)."""
        moving = abs(v_mps) >= 1e-6 or abs(w_radps) >= 1e-6
        if not (self.on and self._waits and moving) or now_s - self._last_s < self.age_s:
            return 0.0
        return self.wait_s


class CycleSync:
    """rtf 0: a node that works in cycles of sim time (the explorer) says after each cycle when
    its next one is due (sim s; ``math.inf``: none). The bridge steps no further than ``slack_s``
    past the earliest due time until that node says again, waiting at most ``wait_s`` of wall
    time (after a wait runs out, not again until that node speaks): its cycle then costs no sim
    time, as the controller's step costs none (CommandSync), and a run's sim times do not
    depend on how busy the machine is. Not at rtf > 0: a real robot's computer pays its cycles."""

    def __init__(self, rtf: float, slack_s: float, wait_s: float):
        self.on = rtf <= 0 and wait_s > 0
        self.slack_s, self.wait_s = slack_s, wait_s
        self._due: dict[str, float] = {}

    def announced(self, node: str, due_s: float) -> None:
        self._due[node] = due_s if due_s > 0 and math.isfinite(due_s) else math.inf

    def blocking(self, now_s: float) -> Optional[str]:
        """The node whose due cycle holds the step at ``now_s``; None: step."""
        if not self.on:
            return None
        for node, due_s in self._due.items():
            if now_s > due_s + self.slack_s:
                return node
        return None

    def gave_up(self, node: str) -> None:
        """A wait for ``node`` ran out: step on without it until it speaks again."""
        self._due[node] = math.inf


class WallShares:
    """Wall time of the bridge's loop by part (waiting for the controller, physics, lidar,
    publishing, ...), summed over a run and reported per simulated second: at rtf 0 the wall
    time per sim second is the run's speed, and the parts say where it goes."""

    def __init__(self):
        self.wall_s: dict[str, float] = defaultdict(float)

    def add(self, part: str, wall_s: float) -> None:
        self.wall_s[part] += wall_s

    def summary(self, sim_s: float) -> str:
        """'wall ms per sim s: wait 41.0, physics 9.5, ... (total 60.5 = 16.5x real time)',
        the parts largest first; '' before any sim time has passed."""
        if sim_s <= 0 or not self.wall_s:
            return ""
        per = sorted(((1e3 * w / sim_s, part) for part, w in self.wall_s.items()), reverse=True)
        total = sum(ms for ms, _ in per)
        parts = ", ".join(f"{part} {ms:.1f}" for ms, part in per)
        return f"wall ms per sim s: {parts} (total {total:.1f} = {1e3 / total:.1f}x real time)"


def footprint_outline(robot: RobotSpec, points: int = 24) -> list[tuple[float, float]]:
    """The robot's outline in base_footprint (m): a round body as ``points`` points on its
    circle, a box as its four corners (counter-clockwise from the front left)."""
    if robot.is_round:
        return [(robot.radius_m * math.cos(a), robot.radius_m * math.sin(a))
                for a in (2 * math.pi * k / points for k in range(points))]
    x0 = robot.footprint_offset_x_m
    hx, hy = 0.5 * robot.footprint_length_m, 0.5 * robot.footprint_width_m
    return [(x0 + hx, hy), (x0 - hx, hy), (x0 - hx, -hy), (x0 + hx, -hy)]


def relative_to_start(start: tuple[float, float, float],
                      pose: tuple[float, float, float]) -> tuple[float, float, float]:
    """A world pose (x m, y m, yaw rad) in the frame of the start pose: the odom frame of
    exact odometry, where rviz draws the true path."""
    sx, sy, syaw = start
    x, y, yaw = pose
    c, s = math.cos(syaw), math.sin(syaw)
    return c * (x - sx) + s * (y - sy), -s * (x - sx) + c * (y - sy), wrap_angle(yaw - syaw)
