"""State-lattice planner for the oriented footprint: facade over ``_native.plan_lattice``.

The 2-D planner (``costmap.plan``) checks the robot's centre against a costmap inflated by the
turning disc, so a box robot is shut out of every gap narrower than that disc. This one plans
over (row, col, heading) (include/turtlebot_recon/lattice_search.hpp): forward and backward
moves along the heading whose swept box, padded by ``margin_m``, stays clear of the obstacle
cells' squares, and turns in place where the turning disc fits or the box's sweep to the next
heading does. Backward moves are slower (``reverse_speed_mps``) and cost as much more: the
way out of a dead end, or off a wall the box cannot turn beside. A round robot's box is its
disc: headings never matter to its collisions and it turns wherever it stands.

Grids are row-major ``(rows, cols)`` with row 0 at the smallest y; poses are (x, y, yaw) in
metres and radians in the grid's frame (``origin`` is the (x, y) of cell (0, 0)'s corner).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import List, Optional, Sequence, Tuple

import numpy as np

from .. import _native, geometry
from ..config import positive, require
from ..control.footprint import BodyCheck
from ..mapping.map_io import OCCUPIED_THRESH
from ..robot import RobotSpec, footprint_args
from .costmap import PlanningError


@dataclass(frozen=True)
class LatticeSettings:
    headings: int = 16                 # lattice headings: 4, 8 or 16 (0, 26.6, 45, 63.4, ... deg)
    margin_m: float = 0.02             # body to obstacle edge, driving: the waffle_pi's 0.306 m box
                                       # passes 0.35 m; an 8-cell 0.40 m gap puts its centre cell
                                       # 0.175 m off one side, 0.022 m beyond the box
    turn_margin_m: float = 0.01        # turning disc to obstacle edge (box robots): the waffle_pi's
                                       # 0.257 m disc turns in the 0.6 m maze, whose centre cells lie
                                       # 0.275 m from the walls
    cost_weight: float = 1.0           # weight of the graded cost c / 252 per metre (as the 2-D A*)
    inflation_m: float = 0.35          # graded cost out to this far beyond the inscribed radius
    cost_scaling_factor: float = 5.0   # 1/m, decay of the graded cost (Nav2's convention)
    cruise_speed_mps: float = 0.0      # turning costs the distance not driven meanwhile:
    turn_speed_radps: float = 0.0      # |dtheta| / turn_speed x cruise_speed metres; 0: the
                                       # robot's (with_robot)
    unknown_is_obstacle: bool = False  # unknown cells collide with the body (never entered anyway)
    reverse_speed_mps: float = 0.1     # backward moves, driven this fast: they cost the forward
                                       # move's distance x cruise / this; 0: forward only

    def validate(self, src: str) -> None:
        require(self.headings in (4, 8, 16), src, "headings", "must be 4, 8 or 16")
        positive(src, self, "margin_m")
        for key in ("cruise_speed_mps", "turn_speed_radps"):
            value = getattr(self, key)
            require(value >= 0, src, key, "must be > 0, or 0 for the robot's")
        require(self.turn_margin_m >= 0, src, "turn_margin_m", "must be >= 0")
        require(self.cost_weight >= 0, src, "cost_weight", "must be >= 0")
        require(self.reverse_speed_mps >= 0, src, "reverse_speed_mps", "must be >= 0 (0: forward only)")
        require(self.inflation_m >= 0, src, "inflation_m", "must be >= 0")
        require(self.cost_scaling_factor >= 0, src, "cost_scaling_factor", "must be >= 0")

    @property
    def turn_cost_m_per_rad(self) -> float:
        """Metres charged per radian turned in place: the cruise distance lost while turning
        (the speeds must be set: ``with_robot``)."""
        return self.cruise_speed_mps / self.turn_speed_radps

    @property
    def reverse_cost_factor(self) -> float:
        """A backward move's cost per forward metre: cruise / reverse speed (at least 1, the
        search's bound); 0 without backward moves (the speeds must be set: ``with_robot``)."""
        if self.reverse_speed_mps <= 0:
            return 0.0
        return max(1.0, self.cruise_speed_mps / self.reverse_speed_mps)

    def with_robot(self, robot: RobotSpec) -> "LatticeSettings":
        """These settings with the speeds left 0 taken from ``robot``: its top speed, and its
        turning speed capped at the controllers' 0.8 rad/s in-place rate
        (``TrackingSettings.rotate_speed_max_radps``)."""
        return replace(self, cruise_speed_mps=self.cruise_speed_mps or robot.max_linear_mps,
                       turn_speed_radps=self.turn_speed_radps or min(0.8, robot.max_angular_radps))

    @classmethod
    def for_robot(cls, robot: RobotSpec, **overrides) -> "LatticeSettings":
        """Defaults (and ``overrides``) with ``robot``'s speeds (``with_robot``)."""
        return cls(**overrides).with_robot(robot)


@dataclass(frozen=True)
class LatticePath:
    poses: np.ndarray        # float (n, 3): x, y (m, the cell centres), yaw (rad), start ... goal
    cells: np.ndarray        # int32 (n, 2): (row, col)
    headings: np.ndarray     # int32 (n,): lattice heading index
    turned: np.ndarray       # bool (n,): reached from the previous pose by turning in place
    reversed: np.ndarray     # bool (n,): reached from the previous pose by a backward move
    cost: float              # the search's cost (m): driven + graded + turning
    length_m: float          # driven
    turned_rad: float        # turned in place (costs settings.turn_cost_m_per_rad per radian)
    reversed_m: float        # of length_m, driven backward


def search_args(robot: RobotSpec, settings: LatticeSettings) -> dict:
    """The footprint and ``settings`` (speeds set: ``with_robot``) as the native searches take them."""
    return dict(**footprint_args(robot), headings=settings.headings, margin_m=settings.margin_m,
                turn_margin_m=settings.turn_margin_m, cost_weight=settings.cost_weight,
                inflation_m=settings.inflation_m, cost_scaling_factor=settings.cost_scaling_factor,
                turn_cost_m_per_rad=settings.turn_cost_m_per_rad,
                occupied_threshold=OCCUPIED_THRESH,
                unknown_is_obstacle=settings.unknown_is_obstacle,
                reverse_cost_factor=settings.reverse_cost_factor)


ESCAPE_RADIUS_M = 1.0   # escape arcs' radius: the end of a box 0.2 m from its wheels swings
                        # 0.2^2 / (2 x 1 m) = 2 cm outward on one (within margin_m)


@dataclass(frozen=True)
class EscapeArc:
    """An arc of ``ESCAPE_RADIUS_M`` from the robot's pose to a lattice pose (``escape_arcs``)."""
    direction: int           # +1 forward, -1 backward
    turn_rad: float          # heading change, + counter-clockwise
    length_m: float          # driven
    cell: Tuple[int, int]    # (row, col) it ends in
    heading: int             # lattice heading index it ends at
    end: Tuple[float, float, float]  # that lattice pose: the cell's centre at the heading (m, rad)
    cost_m: float            # as the lattice counts it: length_m, backward x reverse_cost_factor

    def poses(self, pose: Sequence[float], step_m: float) -> np.ndarray:
        """(n, 3) poses along the arc from ``pose`` (x, y, yaw), every ``step_m`` or less."""
        return _arc(pose, self.turn_rad, self.direction, self.length_m, step_m)


def escape_arcs(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                robot: RobotSpec, pose: Sequence[float], settings: LatticeSettings,
                body: BodyCheck) -> List[EscapeArc]:
    """How a robot that cannot turn where it stands leaves the line it is on: the lattice moves
    straight along headings and turns in place, so a box parallel to a wall and a few
    centimetres beyond margin_m, with no room to turn anywhere along that wall, has no lattice
    way off it; an arc has. Arcs of ``ESCAPE_RADIUS_M`` forward, and backward where the lattice
    drives backward, each turning from the robot's yaw to the lattice heading next to the
    nearest one on either side; kept where the body along them stays clear (``body``, a
    controller's check: its margin, or no nearer than it starts) and the footprint fits at the
    end cell's centre at that heading (margin_m). Cheapest first. For a round robot, none (it
    turns wherever it stands)."""
    if robot.is_round:
        return []
    settings = settings.with_robot(robot)
    yaws = np.array([h[2] for h in _native.lattice_headings(settings.headings)])
    yaw = float(pose[2])
    nearest = int(np.argmin(np.abs(np.remainder(yaws - yaw + math.pi, 2 * math.pi) - math.pi)))
    directions = (1, -1) if settings.reverse_cost_factor > 0 else (1,)
    occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
    grid = SimpleNamespace(occupancy=occupancy, resolution=resolution, origin=origin)
    arcs = []
    for heading in ((nearest + 1) % len(yaws), (nearest - 1) % len(yaws)):
        turn = float(np.remainder(yaws[heading] - yaw + math.pi, 2 * math.pi) - math.pi)
        for direction in directions:
            length = ESCAPE_RADIUS_M * abs(turn)
            sweep = _arc(pose, turn, direction, length, 0.5 * resolution)
            cell = geometry.xy_to_cell(sweep[-1, :2], resolution, origin)
            centre = geometry.cell_to_xy(cell, resolution, origin)
            factor = 1.0 if direction > 0 else settings.reverse_cost_factor
            arc = EscapeArc(direction, turn, length, cell, heading,
                            (centre[0], centre[1], float(yaws[heading])), length * factor)
            if not body.stays_clear(grid, sweep):
                continue
            r, c = cell
            known_free = geometry.inside(r, c, occupancy.shape) and \
                0 <= occupancy[r, c] < OCCUPIED_THRESH
            if not known_free:
                continue
            if footprint_clear(occupancy, resolution, origin, robot, np.array([arc.end]), settings)[0]:
                arcs.append(arc)
    return sorted(arcs, key=lambda a: a.cost_m)


def _arc(pose: Sequence[float], turn: float, direction: int, length: float, step_m: float) -> np.ndarray:
    """(n, 3) poses, ``pose`` first, along the arc turning by ``turn`` over ``length`` m driven
    forward (direction +1) or backward (-1), every ``step_m`` or less."""
    x, y, yaw = (float(v) for v in pose[:3])
    theta = yaw + np.linspace(0.0, turn, max(2, int(math.ceil(length / step_m)) + 1))
    k = turn / (direction * length)                 # curvature per metre of signed distance
    return np.column_stack([x + (np.sin(theta) - math.sin(yaw)) / k,
                            y - (np.cos(theta) - math.cos(yaw)) / k, theta])


def plan_lattice(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                 robot: RobotSpec, start_pose: Sequence[float], goal_xy: Sequence[float],
                 settings: LatticeSettings, goal_yaw: Optional[float] = None) -> LatticePath:
    """Cheapest lattice path from ``start_pose`` (x, y, yaw) to ``goal_xy`` on an int8 occupancy
    grid (-1 unknown, 0..100), at ``goal_yaw`` if given (snapped to the nearest heading).

    The start is the cell holding the robot at the heading nearest its yaw; the goal the cell
    holding ``goal_xy``. Raises PlanningError naming the start or goal when it is off the grid,
    in an obstacle or unknown space, or its footprint collides, and when the goal is unreachable.
    """
    settings = settings.with_robot(robot)
    settings.validate("LatticeSettings")
    start = geometry.xy_to_cell(start_pose[:2], resolution, origin)
    goal = geometry.xy_to_cell(goal_xy, resolution, origin)
    try:
        out = _native.plan_lattice(
            occupancy, resolution, start, float(start_pose[2]), goal, goal_yaw,
            **search_args(robot, settings))
    except ValueError as exc:
        raise PlanningError(str(exc)) from exc
    if not math.isfinite(out["cost"]):
        raise PlanningError(f"plan_lattice: goal {goal} is unreachable from start {start} for "
                            f"{robot.name}'s footprint")
    xy = geometry.cells_to_points(out["cells"], resolution, origin)
    return LatticePath(poses=np.column_stack([xy, out["yaw"]]), cells=out["cells"],
                       headings=out["heading"], turned=out["turned"], reversed=out["reversed"],
                       cost=float(out["cost"]), length_m=float(out["length_m"]),
                       turned_rad=float(out["turned_rad"]), reversed_m=float(out["reversed_m"]))


def lattice_cost_to_come(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                         robot: RobotSpec, pose: Sequence[float], settings: LatticeSettings,
                         snap_radius_m: float = 0.5,
                         escapes: Sequence[EscapeArc] = (),
                         turns_within_m: float = math.inf) -> np.ndarray:
    """float32 (rows, cols): the cheapest ``plan_lattice`` cost (m) from the robot at ``pose``
    (x, y, yaw) to each cell, at whichever heading is cheapest; +inf where the lattice finds no
    path, so a cell is finite exactly when ``plan_lattice`` reaches it. This is where the robot
    can go: a cell where some heading fits (``footprint_costmap`` < 253) may still be out of
    reach (a slot it cannot turn into). The robot starts as the navigator does: at every
    heading that fits where it can turn, else along the line it is on (either way: it backs
    out), else from the nearest cell within ``snap_radius_m`` where it fits; and from the ends of
    ``escapes`` (``escape_arcs``), at their cost.

    ``turns_within_m`` (m of cost): beyond it, the turns the robot makes in place where it can
    turn in place are not counted; there a cell is one search node instead of one per heading
    (~K times cheaper where most of the map lets the robot turn). Which cells are finite does
    not change; costs up to it are exact, beyond it lower bounds (short by those turns)."""
    settings = settings.with_robot(robot)
    settings.validate("LatticeSettings")
    start = geometry.xy_to_cell(pose[:2], resolution, origin)
    return _native.lattice_cost_to_come(
        occupancy, resolution, start, float(pose[2]), float(snap_radius_m),
        **search_args(robot, settings),
        extra_seeds=[(a.cell[0], a.cell[1], a.heading, a.cost_m) for a in escapes],
        turns_within_m=float(turns_within_m))


def footprint_costmap(occupancy: np.ndarray, resolution: float, robot: RobotSpec,
                      settings: LatticeSettings) -> np.ndarray:
    """The graded uint8 costmap ``plan_lattice`` reads: 254 obstacle, 255 unknown, 253 where no
    heading of the footprint fits (exactly: below 253 some lattice heading's pose is clear),
    graded below that (the costmap convention, for the box)."""
    settings.validate("LatticeSettings")
    return _native.footprint_costmap(
        occupancy, resolution, **footprint_args(robot), margin_m=settings.margin_m,
        inflation_m=settings.inflation_m, cost_scaling_factor=settings.cost_scaling_factor,
        occupied_threshold=OCCUPIED_THRESH,
        unknown_is_obstacle=settings.unknown_is_obstacle)


def footprint_clear(occupancy: np.ndarray, resolution: float, origin: Sequence[float],
                    robot: RobotSpec, poses: np.ndarray, settings: LatticeSettings) -> np.ndarray:
    """bool (n,): whether the footprint at each (x, y, yaw) pose, lattice pose or not, keeps
    ``margin_m`` off every obstacle cell's square."""
    settings.validate("LatticeSettings")
    return _native.footprint_clear(
        occupancy, resolution, (float(origin[0]), float(origin[1])),
        np.asarray(poses, dtype=float).reshape(-1, 3), **footprint_args(robot),
        margin_m=settings.margin_m, occupied_threshold=OCCUPIED_THRESH,
        unknown_is_obstacle=settings.unknown_is_obstacle)
