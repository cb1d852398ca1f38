"""State-lattice planner for the oriented footprint (planning.lattice, lattice_search.hpp).

Every returned path is checked by ``check_path``, written here independently of the C++: each
pose, and poses every centimetre along each forward move, keeps the body ``margin_m`` off every
obstacle cell's square; every turn in place happens where the turning disc keeps
``turn_margin_m`` off them; consecutive poses are one lattice move apart.

Maps are hand-made at 0.05 m, origin (0, 0): cell (row, col) spans x in [col, col + 1] x 0.05,
y in [row, row + 1] x 0.05. The waffle_pi's box (config/robots): 0.281 m long, 0.306 m wide,
its centre 0.064 m behind base_footprint, so it reaches 0.0765 m ahead, 0.2045 m behind and
0.153 m to each side; turning disc 0.257 m. Default margins: 0.02 m driving, 0.01 m turning.
"""
import math

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.config import ConfigError
from turtlebot_recon.planning import (CostmapSettings, LatticeSettings, PlannerSettings,
                                      PlanningError, footprint_clear, footprint_costmap,
                                      lattice_cost_to_come, make_costmap, plan, plan_lattice)
from turtlebot_recon.planning.costmap import cost_model
from turtlebot_recon.robot import load_robot

RES = 0.05
ORIGIN = (0.0, 0.0)
WAFFLE = load_robot("turtlebot3_waffle_pi")
BURGER = load_robot("turtlebot3_burger")
HEADINGS = _native.lattice_headings(16)       # (drow, dcol, yaw) per heading


# ---------------------------------------------------------------- factories and the check

def centre(row, col, yaw=0.0):
    """The pose (x, y, yaw) at the centre of cell (row, col)."""
    return ((col + 0.5) * RES, (row + 0.5) * RES, yaw)


def walled(rows, cols):
    """Free int8 occupancy with a one-cell wall all round."""
    occ = np.zeros((rows, cols), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    return occ


def two_rooms(gap_cells):
    """Two 1.9 x 2.9 m rooms joined through a 0.2 m wall (columns 38-41) by a gap of
    ``gap_cells`` rows centred on row 30 (8 cells: rows 26-33, y in [1.30, 1.70])."""
    occ = walled(60, 80)
    occ[:, 38:42] = 100
    low = 30 - gap_cells // 2
    occ[low:low + gap_cells, 38:42] = 0
    return occ


def l_corridor(corner_room):
    """A 0.45 m (9-cell) corridor: east along rows 10-18 from column 3 to 40, then north along
    columns 32-40 up to row 55. With ``corner_room`` the corner widens to a 0.8 m square (rows
    6-21, columns 28-43)."""
    occ = np.full((60, 60), 100, np.int8)
    occ[10:19, 3:41] = 0
    occ[10:56, 32:41] = 0
    if corner_room:
        occ[6:22, 28:44] = 0
    return occ


def obstacle_centres(occ):
    rows, cols = np.nonzero(occ >= 65)
    return (cols + 0.5) * RES, (rows + 0.5) * RES


def square_distance(px, py, cx, cy):
    """Distance from the point(s) (px, py) to the axis-aligned cell squares centred at (cx, cy)."""
    dx = np.maximum(np.abs(px - cx) - 0.5 * RES, 0.0)
    dy = np.maximum(np.abs(py - cy) - 0.5 * RES, 0.0)
    return np.hypot(dx, dy)


def body_clearance(robot, pose, cx, cy):
    """Distance (m) from the body at ``pose`` to the nearest obstacle square, 0 when they meet.

    Round: centre to square, less the radius. Box: two disjoint convex polygons are nearest at a
    vertex of one of them, so take (a) each square corner to the box, in the robot's frame, and
    (b) each box corner to the squares, in the map's; overlapping ones have a vertex inside the
    other (a 5 cm square cannot cross the box from side to side), which (a) or (b) finds at 0.
    """
    x, y, yaw = pose
    if robot.is_round:
        return float((square_distance(x, y, cx, cy) - robot.radius_m).min(initial=np.inf))
    x0 = robot.footprint_offset_x_m - 0.5 * robot.footprint_length_m
    x1 = robot.footprint_offset_x_m + 0.5 * robot.footprint_length_m
    y1 = 0.5 * robot.footprint_width_m
    c, s = math.cos(yaw), math.sin(yaw)
    best = np.inf
    h = 0.5 * RES
    for sx in (-h, h):                                     # (a)
        for sy in (-h, h):
            px, py = cx + sx - x, cy + sy - y
            u, v = c * px + s * py, -s * px + c * py
            du = np.maximum(np.maximum(x0 - u, u - x1), 0.0)
            dv = np.maximum(np.abs(v) - y1, 0.0)
            best = min(best, np.hypot(du, dv).min(initial=np.inf))
    for bx in (x0, x1):                                    # (b)
        for by in (-y1, y1):
            wx, wy = x + c * bx - s * by, y + s * bx + c * by
            best = min(best, square_distance(wx, wy, cx, cy).min(initial=np.inf))
    return float(best)


def turning_disc(robot, settings):
    """Radius the turning disc must keep clear of obstacle squares: the circumscribed radius plus
    the turning margin (a round robot: its body, plus the driving margin)."""
    if robot.is_round:
        return robot.radius_m + settings.margin_m
    return robot.radius_m + settings.turn_margin_m


def check_path(path, robot, settings, occ):
    """Assert that ``path`` is a chain of lattice moves whose body stays clear (see the module)."""
    cx, cy = obstacle_centres(occ)
    margin, tiny = settings.margin_m, 1e-9
    n = len(path.poses)
    assert path.poses.shape == (n, 3) and path.cells.shape == (n, 2) and path.turned.shape == (n,)
    assert not path.turned[0]
    length = turned = reversed_m = 0.0
    for i in range(n):
        (r, c), k = path.cells[i], int(path.headings[i])
        assert occ[r, c] >= 0, f"pose {i} on unknown cell {(r, c)}"
        assert math.isclose(path.poses[i, 2], HEADINGS[k][2])
        assert body_clearance(robot, path.poses[i], cx, cy) >= margin - tiny, f"pose {i} collides"
        if i == 0:
            continue
        (r0, c0), k0 = path.cells[i - 1], int(path.headings[i - 1])
        if path.turned[i]:
            # a turn in place to the next heading, where the disc fits or, failing that, where
            # the body keeps the margin at every yaw in between (0.5 deg apart; the lattice
            # samples 3 deg, whose corner slivers are < 0.1 mm deep)
            assert (r, c) == (r0, c0) and (k - k0) % 16 in (1, 15), f"pose {i} is no turn"
            x, y, _ = path.poses[i]
            clear = square_distance(x, y, cx, cy).min(initial=np.inf)
            if clear < turning_disc(robot, settings) - tiny:
                assert not robot.is_round, f"turn at pose {i} is too tight"
                a0 = HEADINGS[k0][2]
                delta = math.remainder(HEADINGS[k][2] - a0, 2 * math.pi)
                for a in np.linspace(a0, a0 + delta, int(math.ceil(abs(delta) / math.radians(0.5))) + 1):
                    assert body_clearance(robot, (x, y, a), cx, cy) >= margin - 1e-4, \
                        f"turn at pose {i} sweeps the body onto an obstacle at {math.degrees(a):.1f} deg"
            turned += abs(math.remainder(HEADINGS[k][2] - HEADINGS[k0][2], 2 * math.pi))
        else:
            # one lattice vector forward (or back); the body clear every centimetre along it
            dr, dc, yaw = HEADINGS[k0]
            sign = -1 if path.reversed[i] else 1
            assert k == k0 and (r - r0, c - c0) == (sign * dr, sign * dc), f"pose {i} is no move"
            step = math.hypot(dr, dc) * RES
            length += step
            reversed_m += step if sign < 0 else 0.0
            x0, y0, _ = path.poses[i - 1]
            for t in np.linspace(0.0, 1.0, int(math.ceil(step / 0.01)) + 1)[1:-1]:
                pose = (x0 + sign * t * dc * RES, y0 + sign * t * dr * RES, yaw)
                assert body_clearance(robot, pose, cx, cy) >= margin - tiny, f"move to pose {i} collides"
    assert not (path.turned & path.reversed).any()
    assert math.isclose(path.length_m, length, abs_tol=1e-9)
    assert math.isclose(path.reversed_m, reversed_m, abs_tol=1e-9)
    assert math.isclose(path.turned_rad, turned, abs_tol=1e-9)


def lattice(occ, robot, start_pose, goal_xy, goal_yaw=None, **overrides):
    settings = LatticeSettings.for_robot(robot, **overrides)
    path = plan_lattice(occ, RES, ORIGIN, robot, start_pose, goal_xy, settings, goal_yaw=goal_yaw)
    check_path(path, robot, settings, occ)
    return path


# ---------------------------------------------------------------- headings

def test_headings_are_the_lattice_vectors():
    # 16 headings: (dx, dy) = (1,0), (2,1), (1,1), (1,2) and their turns by 90 degrees;
    # heading 1 is atan2(1, 2) = 26.57 deg, heading 3 atan2(2, 1) = 63.43 deg.
    assert [(dr, dc) for dr, dc, _ in HEADINGS[:5]] == [(0, 1), (1, 2), (1, 1), (2, 1), (1, 0)]
    assert HEADINGS[1][2] == pytest.approx(math.atan2(1, 2))
    assert HEADINGS[8][:2] == (0, -1) and HEADINGS[12][:2] == (-1, 0)
    for dr, dc, yaw in HEADINGS:
        assert yaw == pytest.approx(math.atan2(dr, dc))
    assert [(dr, dc) for dr, dc, _ in _native.lattice_headings(4)] == [(0, 1), (1, 0), (0, -1), (-1, 0)]
    assert len(_native.lattice_headings(8)) == 8
    with pytest.raises(ValueError, match="4, 8 or 16"):
        _native.lattice_headings(12)


# ---------------------------------------------------------------- the footprint test

@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_pose_check_is_exact_to_the_obstacle_edges(robot):
    # A pose is accepted (as a start that is also the goal) exactly when body_clearance, the
    # plain check above, finds the body margin_m or more from every obstacle square: the margin
    # is measured to the squares' edges, neither more cautious nor less. Poses within 1e-6 m of
    # the boundary are left out (rounding).
    rng = np.random.default_rng(11)
    settings = LatticeSettings.for_robot(robot)
    occ = walled(30, 30)
    occ[rng.random(occ.shape) < 0.03] = 100
    cx, cy = obstacle_centres(occ)
    outcomes = set()
    for _ in range(300):
        r, c = rng.integers(1, 29, 2)
        if occ[r, c] != 0:
            continue
        k = int(rng.integers(16))
        pose = centre(r, c, HEADINGS[k][2])
        clearance = body_clearance(robot, pose, cx, cy)
        if abs(clearance - settings.margin_m) < 1e-6:
            continue
        try:
            plan_lattice(occ, RES, ORIGIN, robot, pose, pose[:2], settings)
            accepted = True
        except PlanningError as exc:
            assert "footprint" in str(exc)
            accepted = False
        assert accepted == (clearance >= settings.margin_m), (r, c, k, clearance)
        outcomes.add(accepted)
    assert outcomes == {True, False}


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_footprint_clear_at_any_pose_is_exact(robot):
    # footprint_clear (for poses off the lattice: a controller's look-ahead) agrees with
    # body_clearance at random positions and yaws, boundary cases (1e-6 m) left out; origin
    # (1, -2) shifts the map, and the poses with it.
    rng = np.random.default_rng(12)
    settings = LatticeSettings.for_robot(robot)
    occ = walled(30, 30)
    occ[rng.random(occ.shape) < 0.03] = 100
    cx, cy = obstacle_centres(occ)
    poses = np.column_stack([rng.uniform(0.0, 1.5, (400, 2)), rng.uniform(-math.pi, math.pi, 400)])
    clear = footprint_clear(occ, RES, (1.0, -2.0), robot, poses + (1.0, -2.0, 0.0), settings)
    margins = np.array([body_clearance(robot, pose, cx, cy) for pose in poses])
    sure = np.abs(margins - settings.margin_m) > 1e-6
    assert np.array_equal(clear[sure], margins[sure] >= settings.margin_m)
    assert clear.any() and not clear.all()
    # off the grid is free unless unknown_is_obstacle; non-finite poses are never clear
    far = [[-5.0, -5.0, 0.0], [math.nan, 0.5, 0.0]]
    assert footprint_clear(occ, RES, ORIGIN, robot, far, settings).tolist() == [True, False]
    strict = LatticeSettings.for_robot(robot, unknown_is_obstacle=True)
    assert not footprint_clear(occ, RES, ORIGIN, robot, far, strict).any()


def test_footprint_costmap_values():
    # The waffle_pi's box reaches 0.0765 m ahead of base_footprint, its least reach: with the
    # 0.02 m margin, r_in = 0.0965 m. One obstacle cell at (20, 20); cell (20, 20 + k) lies
    # k x 0.05 - 0.025 m from its edge: 253 while that is < r_in, then
    # floor(252 exp(-5 (d - r_in))) up to r_in + 0.35 = 0.4465 m, 0 beyond.
    occ = np.zeros((41, 41), np.int8)
    occ[20, 20] = 100
    occ[0, 0] = -1
    cost = footprint_costmap(occ, RES, WAFFLE, LatticeSettings.for_robot(WAFFLE))
    expected = {0: 254,          # the obstacle
                1: 253, 2: 253,  # 0.025 m, 0.075 m < 0.0965 m: no heading fits
                3: 218,          # 0.125 m: floor(252 e^-0.1425) = floor(218.53)
                4: 170,          # 0.175 m: floor(252 e^-0.3925) = floor(170.19)
                9: 48,           # 0.425 m: floor(252 e^-1.6425) = floor(48.75)
                10: 0}           # 0.475 m: beyond the band
    for k, value in expected.items():
        assert cost[20, 20 + k] == value and cost[20 - k, 20] == value, k
    assert cost[0, 0] == 255 and cost.dtype == np.uint8 and cost.shape == occ.shape


def test_footprint_costmap_253_exactly_where_no_heading_fits():
    # A 0.25 m (5-cell) slot: its middle cell lies 0.125 m from both sides, beyond the box's
    # least reach (0.0965 m with the margin), yet the box is 0.281 x 0.306 m and fits at no
    # heading: 253 all along it. In a 0.40 m slot the box fits along it: below 253. Everywhere,
    # < 253 exactly where footprint_clear finds some lattice heading's pose clear.
    occ = np.full((40, 60), 100, np.int8)
    occ[5:10, 5:55] = 0                   # 0.25 m high, 2.5 m long
    occ[20:28, 5:55] = 0                  # 0.40 m
    settings = LatticeSettings.for_robot(WAFFLE)
    cost = footprint_costmap(occ, RES, WAFFLE, settings)
    assert (cost[5:10, 5:55] >= 253).all()
    assert (cost[23:25, 10:50] < 253).all()
    cells = np.argwhere(occ == 0)
    poses = np.array([centre(r, c, yaw) for r, c in cells for _, _, yaw in HEADINGS])
    fits = footprint_clear(occ, RES, ORIGIN, WAFFLE, poses, settings).reshape(len(cells), 16)
    assert np.array_equal(cost[cells[:, 0], cells[:, 1]] < 253, fits.any(axis=1))


# ---------------------------------------------------------------- gaps

@pytest.mark.parametrize("gap_cells, passes", [(8, True), (7, True), (6, False)])
def test_waffle_drives_straight_through_the_gaps_its_box_fits(gap_cells, passes):
    # The box is 0.306 m wide; with 0.02 m margins it needs 0.346 m.
    #  8 cells (0.40 m): the gap's middle is a cell boundary; the centre cell nearest it lies
    #    0.175 m from one side, 0.175 - 0.153 = 0.022 >= 0.02 m: passes.
    #  7 cells (0.35 m): the middle cell lies 0.175 m from both sides: passes.
    #  6 cells (0.30 m): narrower than the box itself: no path.
    occ = two_rooms(gap_cells)
    start, goal = centre(30, 10, yaw=1.0), centre(30, 70)[:2]
    if not passes:
        with pytest.raises(PlanningError, match="unreachable"):
            lattice(occ, WAFFLE, start, goal)
        return
    path = lattice(occ, WAFFLE, start, goal)
    in_wall = (path.cells[:, 1] >= 38) & (path.cells[:, 1] <= 41)
    assert in_wall.sum() >= 4
    # aligned with the gap: heading 0 (east) all the way through, never turning in it
    assert (path.headings[in_wall] == 0).all() and not path.turned[in_wall].any()
    # The robot starts at heading 3 (63.4 deg, nearest 1.0 rad), turns right to 0 in the room
    # (3 turns: 63.4 deg = 1.107 rad) and drives 60 cells east: 3.0 m.
    assert path.length_m == pytest.approx(3.0)
    assert path.turned_rad == pytest.approx(math.atan2(2, 1))


def test_disc_planner_finds_no_path_through_the_040_gap():
    # Today's 2-D planner inflates by the turning disc: inscribed radius 0.257 + one cell
    # diagonal 0.071 = 0.328 m > the gap's half-width 0.20 m, so every cell of the gap is
    # inscribed (253) and the rooms are cut apart.
    occ = two_rooms(8)
    costmap = make_costmap(occ, RES, CostmapSettings.for_robot(WAFFLE))
    assert (costmap[26:34, 38:42] >= 253).all()
    with pytest.raises(PlanningError, match="unreachable"):
        plan(costmap, (30, 10), (30, 70), PlannerSettings())


def test_burger_passes_the_030_gap():
    # The burger's disc, 0.105 m + 0.02 m margin: the 6-cell gap's centre cells lie 0.125 m and
    # 0.175 m from its sides: 0.125 >= 0.125 passes (the margin is measured to the edge).
    path = lattice(two_rooms(6), BURGER, centre(30, 10), centre(30, 70)[:2])
    assert path.length_m == pytest.approx(3.0)


# ---------------------------------------------------------------- turning

def test_turns_where_the_disc_fits_or_the_sweep_clears_l_corridor():
    # The 0.45 m corridor holds the box (0.225 m each side of the middle cell, 0.072 m spare)
    # but not the turning disc (0.257 + 0.01 = 0.267 m > 0.225 m), nor the box turned 45 deg:
    # forward only, the robot turns the 90 degree corner only where the 0.8 m corner room gives
    # it room; check_path checks the disc or the sweep at every turn.
    start, goal = centre(14, 10), centre(50, 36)[:2]
    path = lattice(l_corridor(corner_room=True), WAFFLE, start, goal, reverse_speed_mps=0.0)
    turns = path.cells[path.turned]
    assert len(turns) >= 4            # four 22.5 deg-ish steps make the 90 degrees
    assert path.turned_rad == pytest.approx(math.pi / 2)
    assert not path.reversed.any()
    # with backward moves allowed, the room's plan needs none of them
    again = lattice(l_corridor(corner_room=True), WAFFLE, start, goal)
    assert not again.reversed.any() and again.cost == pytest.approx(path.cost)


def test_a_box_squares_up_in_a_corridor_too_narrow_for_its_disc():
    # A 0.5 m corridor (rows 10-19): the waffle_pi's disc (0.267 m with its margin) fits
    # nowhere, but its box at 26.6 deg does, and the sweep from there to 0 deg clears the walls:
    # the lattice turns it partway (the old disc-only rule left it no move but into the wall).
    occ = np.full((30, 120), 100, np.int8)
    occ[10:20, 1:119] = 0
    settings = LatticeSettings.for_robot(WAFFLE)
    yaw = HEADINGS[1][2]
    rows = [r for r in range(10, 20)
            if footprint_clear(occ, RES, ORIGIN, WAFFLE, np.array([centre(r, 20, yaw)]), settings)[0]]
    assert rows
    start = centre(rows[len(rows) // 2], 20, yaw)
    path = lattice(occ, WAFFLE, start, centre(15, 100)[:2])
    first_turn = int(np.argmax(path.turned))
    assert path.turned.any() and first_turn <= 2          # it squares up at once
    x, y, _ = path.poses[first_turn]
    disc = WAFFLE.radius_m + settings.turn_margin_m
    assert min(y - 0.5, 1.0 - y) < disc                   # where the disc does not fit
    assert path.headings[-1] == 0


def test_a_turn_costs_the_cruise_distance_lost_turning():
    # Open floor, cost_weight 0: from (30, 20) facing east to (50, 20) facing north. Any path
    # must turn at least 90 degrees (its moves add up to a vector due north, the goal heading
    # is north) and drive at least 20 cells, so the optimum turns on the spot and drives:
    # 1.0 m + pi/2 rad x (0.26 m/s / 0.8 rad/s) = 1.0 + 0.5105 = 1.5105 m.
    occ = walled(80, 80)
    path = lattice(occ, WAFFLE, centre(30, 20), centre(50, 20)[:2], goal_yaw=math.pi / 2,
                   cost_weight=0.0)
    assert path.cost == pytest.approx(1.0 + math.pi / 2 * 0.26 / 0.8)
    assert path.turned_rad == pytest.approx(math.pi / 2)
    assert path.headings[-1] == 4 and path.turned[1:5].all()   # four turns first, at the start


# ---------------------------------------------------------------- round robots

def test_burger_straight_path_costs_what_the_grid_search_does():
    # 2 m east along row 40 of an open 80 x 120 room, 1.95 m from the walls: graded cost 0 on
    # both maps, no turn; both cost 40 x 0.05 = 2.0 m.
    occ = walled(80, 120)
    costmap = make_costmap(occ, RES, CostmapSettings.for_robot(BURGER))
    _, grid_cost = _native.astar(costmap, (40, 30), (40, 70), **cost_model(PlannerSettings(visit_sensitivity=0.0), RES))
    path = lattice(occ, BURGER, centre(40, 30), centre(40, 70)[:2])
    assert grid_cost == pytest.approx(2.0) and path.cost == pytest.approx(2.0)


def test_burger_path_cost_close_to_the_grid_search_around_a_block():
    # Around a 1 x 1 m block from (10, 10) to (50, 70), length only (cost_weight 0). The
    # lattice's 16 headings go straighter than 8-connected moves: a (2, 1) step is sqrt 5 =
    # 2.236 cells against 1 + sqrt 2 = 2.414, at most 7.4 % shorter; and it pays for its turns,
    # which may cost it a little length. So its length lies within [0.92, 1.01] of the grid's.
    occ = walled(60, 80)
    occ[20:40, 30:50] = 100
    costmap = make_costmap(occ, RES, CostmapSettings.for_robot(BURGER))
    _, grid_cost = _native.astar(costmap, (10, 10), (50, 70),
                                 **cost_model(PlannerSettings(visit_sensitivity=0.0, cost_weight=0.0), RES))
    path = lattice(occ, BURGER, centre(10, 10), centre(50, 70)[:2], cost_weight=0.0)
    assert 0.92 * grid_cost <= path.length_m <= 1.01 * grid_cost
    assert path.cost == pytest.approx(path.length_m + path.turned_rad * 0.22 / 0.8)


# ---------------------------------------------------------------- random maps

def random_blocks(rng, n):
    """A walled 50 x 60 grid with ``n`` random blocks of 2-11 cells a side."""
    occ = walled(50, 60)
    for _ in range(n):
        h, w = rng.integers(2, 12, 2)
        r, c = rng.integers(1, 50 - h), rng.integers(1, 60 - w)
        occ[r:r + h, c:c + w] = 100
    return occ


def roomy_cells(occ):
    """(row, col) of the free cells more than 0.35 m from every obstacle."""
    clear = _native.distance_transform((occ == 100).astype(np.uint8), RES) > 0.35
    return np.argwhere(clear & (occ == 0))


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_random_maps_paths_are_valid_and_deterministic(robot):
    rng = np.random.default_rng(4)
    found = 0
    for trial in range(10):
        occ = random_blocks(rng, 8)
        occ[rng.random(occ.shape) < 0.02] = -1          # a few unknown cells
        free = roomy_cells(occ)                            # every heading fits, even turning
        a, b = free[rng.choice(len(free), 2, replace=False)]
        start, goal = centre(*a, yaw=rng.uniform(-math.pi, math.pi)), centre(*b)[:2]
        try:
            path = lattice(occ, robot, start, goal)
        except PlanningError as exc:
            assert "unreachable" in str(exc), trial
            continue
        found += 1
        again = lattice(occ, robot, start, goal)
        for field in ("poses", "cells", "headings", "turned"):
            assert np.array_equal(getattr(path, field), getattr(again, field)), (trial, field)
        assert path.cost == again.cost
    assert found >= 6


# ---------------------------------------------------------------- where the robot can go

def reach(occ, robot, pose, snap_radius_m=0.5):
    return lattice_cost_to_come(occ, RES, ORIGIN, robot, pose, LatticeSettings.for_robot(robot),
                                snap_radius_m)


@pytest.mark.parametrize("corner_room", [False, True])
def test_cost_to_come_is_where_the_lattice_goes_not_where_the_box_fits(corner_room):
    # Forward only: without the corner room the north leg holds the box at heading 90 deg (the
    # costmap says some heading fits there) but the robot coming along the east leg cannot turn
    # into it: the explorer must not count a frontier there as reachable. With the room it turns
    # there.
    occ = l_corridor(corner_room)
    start = centre(14, 10)
    forward_only = LatticeSettings.for_robot(WAFFLE, reverse_speed_mps=0.0)
    field = lattice_cost_to_come(occ, RES, ORIGIN, WAFFLE, start, forward_only)
    costmap = footprint_costmap(occ, RES, WAFFLE, forward_only)
    assert costmap[50, 36] < 253 and costmap[30, 36] < 253
    assert np.isfinite(field[14, 10:37]).all()
    assert (field[14, 10] == 0.0)
    if corner_room:
        path = lattice(occ, WAFFLE, start, centre(50, 36)[:2], reverse_speed_mps=0.0)
        assert field[50, 36] == pytest.approx(path.cost, rel=1e-5)
    else:
        assert np.isinf(field[30:56, 32:41]).all()
    assert np.isinf(field[occ >= 65]).all()


def test_backward_moves_take_the_box_round_a_corner_it_cannot_turn_in():
    # The same 0.45 m corner without its room: no turn in place of 90 deg fits there, but a
    # multi-point turn does (forward and back, turning partway where the sweep clears), and
    # the field counts the north leg as reachable where plan_lattice reaches it that way.
    occ = l_corridor(corner_room=False)
    start, goal = centre(14, 10), centre(50, 36)
    with pytest.raises(PlanningError, match="unreachable"):
        lattice(occ, WAFFLE, start, goal[:2], reverse_speed_mps=0.0)
    path = lattice(occ, WAFFLE, start, goal[:2])
    assert path.reversed.any() and path.reversed_m > 0
    assert path.cost >= path.length_m + path.reversed_m * (0.26 / 0.1 - 1) - 1e-6
    field = reach(occ, WAFFLE, start)
    assert field[50, 36] == pytest.approx(path.cost, rel=1e-5)


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_cost_to_come_is_finite_exactly_where_plan_lattice_finds_a_path(robot):
    rng = np.random.default_rng(11)
    settings = LatticeSettings.for_robot(robot)
    checked = unreachable = 0
    for trial in range(6):
        occ = random_blocks(rng, 10)
        occ[:, 50] = 100                                   # a sealed room beyond column 50
        free = roomy_cells(occ)                            # the robot can turn where it starts
        start = centre(*free[rng.integers(len(free))], yaw=rng.uniform(-math.pi, math.pi))
        field = reach(occ, robot, start)
        fits = np.argwhere(footprint_costmap(occ, RES, robot, settings) < 253)
        for cell in fits[rng.choice(len(fits), 12, replace=False)]:
            try:
                cost = plan_lattice(occ, RES, ORIGIN, robot, start, centre(*cell)[:2], settings).cost
            except PlanningError as exc:
                assert "unreachable" in str(exc)
                cost = math.inf
            assert np.isfinite(field[tuple(cell)]) == math.isfinite(cost), (trial, cell)
            if math.isfinite(cost):      # the field starts at the exact yaw, the plan snaps it to
                # the nearest heading: they differ by the turn cost of half the widest gap
                # between two headings, (1, 0) to (2, 1)
                half_gap = 0.5 * math.atan2(1, 2)
                assert abs(field[tuple(cell)] - cost) <= settings.turn_cost_m_per_rad * half_gap + 1e-4
            checked += 1
            unreachable += not math.isfinite(cost)
    assert checked == 72 and unreachable >= 3


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_cost_to_come_is_the_least_plan_cost_from_a_lattice_heading(robot):
    # Started at a lattice heading (yaw 0) where the robot turns, the field's seeds cost
    # exactly the turns plan_lattice charges: the two agree to float32's precision (the
    # field's bucket queue settles every state at its least cost, in any order within a
    # bucket: a bucket narrower than the cheapest move or turn could not hold both ends).
    rng = np.random.default_rng(5)
    settings = LatticeSettings.for_robot(robot)
    compared = 0
    for trial in range(4):
        occ = random_blocks(rng, 10)
        free = roomy_cells(occ)
        start = centre(*free[rng.integers(len(free))], yaw=0.0)
        field = reach(occ, robot, start)
        for cell in free[rng.choice(len(free), 10, replace=False)]:
            try:
                cost = plan_lattice(occ, RES, ORIGIN, robot, start, centre(*cell)[:2], settings).cost
            except PlanningError:
                assert not np.isfinite(field[tuple(cell)])
                continue
            assert field[tuple(cell)] == pytest.approx(cost, rel=1e-6, abs=1e-5), (trial, cell)
            compared += 1
    assert compared >= 30


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_turns_within_m_keeps_the_reach_and_the_near_costs(robot):
    # Past turns_within_m a cell where the robot turns in place is one node (any heading):
    # the same cells are finite (random clutter, and the 0.45 m corner only backing gets the
    # box round), costs up to the bound are the exact ones, costs beyond it are at most the
    # exact ones (the turns there are not counted) and, where paths turn, less.
    # (Dense clutter, seeds 18 and 27: a disc moved between two cells where it fits may still
    # graze a corner between them; a box moved along its axis may not.)
    settings = LatticeSettings.for_robot(robot)
    maps = [(random_blocks(np.random.default_rng(seed), 30), seed) for seed in (18, 27)]
    maps += [(l_corridor(room), None) for room in (False, True)]
    dropped = 0
    for occ, seed in maps:
        start = centre(14, 10)
        if seed is not None:
            rng = np.random.default_rng(seed + 100)
            free = roomy_cells(occ)
            start = centre(*free[rng.integers(len(free))], yaw=rng.uniform(-math.pi, math.pi))
        exact = reach(occ, robot, start)
        assert np.isfinite(exact).sum() > 100
        for bound in (0.0, 1.0):
            field = lattice_cost_to_come(occ, RES, ORIGIN, robot, start, settings, 0.5,
                                         turns_within_m=bound)
            finite = np.isfinite(exact)
            assert np.array_equal(np.isfinite(field), finite), bound
            assert (field[finite] <= exact[finite] + 1e-5).all()
            near = finite & (exact <= bound)
            assert np.allclose(field[near], exact[near], rtol=1e-6, atol=1e-6)
            dropped += int((field[finite] < exact[finite] - 0.05).sum())
    assert dropped > 100


def test_cost_to_come_starts_as_the_navigator_does():
    # Facing away from a wall with the rear within margin_m of it (row 4): the box fits there
    # only across the wall or facing it, going nowhere; the first cell straight ahead where it
    # fits facing away (row 5) starts the field, as the navigator starts its plans there.
    occ = walled(40, 40)
    field = reach(occ, WAFFLE, centre(4, 20, yaw=math.pi / 2))
    assert field[5, 20] == pytest.approx(RES)
    assert np.isfinite(field[20, 20]) and np.isfinite(field[20, 5])
    # Nothing fits at the robot's cell nor ahead (it faces the wall from too near): the nearest
    # cells where some heading fits, at the distance to them; none within snap_radius_m: inf.
    start = centre(2, 20, yaw=-math.pi / 2)
    field = reach(occ, WAFFLE, start)
    first = np.unravel_index(np.argmin(field), field.shape)
    assert np.isinf(field[2, 20]) and 0 < field.min() <= 0.5
    assert field.min() == pytest.approx(RES * math.hypot(first[0] - 2, first[1] - 20), rel=1e-6)
    assert np.isinf(reach(occ, WAFFLE, start, snap_radius_m=0.04)).all()


def test_unknown_cells_are_never_entered():
    # The gap filled with unknown cells: the centre may not cross them, the rooms are apart.
    occ = two_rooms(8)
    occ[26:34, 38:42] = -1
    with pytest.raises(PlanningError, match="unreachable"):
        lattice(occ, WAFFLE, centre(30, 10), centre(30, 70)[:2])
    # Unknown cells beside a known 0.30 m strip, narrower than the box: the body may overlap
    # them (they are no obstacles), its centre stays on known cells (check_path); as obstacles
    # (unknown_is_obstacle) they leave the box no room.
    occ = np.full((40, 80), -1, np.int8)
    occ[16:22, 2:78] = 0
    path = lattice(occ, WAFFLE, centre(18, 10), centre(18, 70)[:2])
    assert path.length_m == pytest.approx(3.0)
    with pytest.raises(PlanningError, match="start .* at heading 0 deg"):
        lattice(occ, WAFFLE, centre(18, 10), centre(18, 70)[:2], unknown_is_obstacle=True)


# ---------------------------------------------------------------- what searches share

def test_a_map_changed_in_place_is_planned_on_as_it_stands():
    # The footprint's regions and the map's products are cached between calls (lattice_grid.hpp),
    # the map keyed by its bytes: the same array, its gap closed, then reopened, is planned on as
    # it stands each time. Two rooms through the 0.6 m gap (rows 24-35): 3.0 m straight east.
    occ = two_rooms(12)
    settings = LatticeSettings.for_robot(BURGER)
    first = lattice(occ, BURGER, centre(30, 10), centre(30, 70)[:2])
    assert first.length_m == pytest.approx(3.0)
    occ[24:36, 38:42] = 100
    with pytest.raises(PlanningError, match="unreachable"):
        plan_lattice(occ, RES, ORIGIN, BURGER, centre(30, 10), centre(30, 70)[:2], settings)
    assert (footprint_costmap(occ, RES, BURGER, settings)[24:36, 38:42] == 254).all()
    occ[24:36, 38:42] = 0
    again = lattice(occ, BURGER, centre(30, 10), centre(30, 70)[:2])
    assert again.cost == first.cost and np.array_equal(again.cells, first.cells)


def test_cached_pieces_are_kept_apart_by_robot_and_settings():
    # Three configurations (the cache keeps two of each, so one is always rebuilt) planned in
    # one order, then in the reverse one: each plans the same path both times, and the three
    # cost differently (turning 0.325 / 0.275 m per rad; graded costs from r_in + margin_m), so
    # a cache that handed one configuration another's pieces would show.
    occ = random_blocks(np.random.default_rng(3), 10)
    free = roomy_cells(occ)
    configs = [(WAFFLE, {}), (BURGER, {}), (WAFFLE, {"margin_m": 0.06})]

    def plans(order, start, goal):
        out = {}
        for i in order:
            robot, overrides = configs[i]
            out[i] = plan_lattice(occ, RES, ORIGIN, robot, start, goal,
                                  LatticeSettings.for_robot(robot, **overrides))
        return out

    start = centre(*free[0], yaw=0.0)
    for cell in free[::-1]:        # the farthest goal that all three reach
        goal = centre(*cell)[:2]
        try:
            forward = plans([0, 1, 2], start, goal)
            break
        except PlanningError:
            continue
    backward = plans([2, 1, 0, 2], start, goal)
    for i in range(3):
        assert backward[i].cost == forward[i].cost and np.array_equal(backward[i].cells, forward[i].cells)
    costs = sorted(p.cost for p in forward.values())
    assert costs[0] < costs[1] < costs[2]


@pytest.mark.parametrize("robot", [WAFFLE, BURGER], ids=lambda r: r.name)
def test_a_long_detour_costs_what_the_exhaustive_search_finds(robot):
    # Start and goal 2 m apart either side of a wall whose only opening (0.55 m, rows 1-11) lies
    # 1.7 m below them: the heuristic's search from the goal, aimed at the start, must be resumed
    # far outside the ellipse round the straight line, and stays exact there: the plan costs what
    # the lattice Dijkstra without a heuristic (lattice_cost_to_come) finds, the robot starting
    # at a lattice heading where it turns (see test_cost_to_come_is_the_least_plan_cost_...).
    # Forward moves only: with backward ones the least-turning term is admissible but not
    # consistent (lattice_search.hpp), and here the plan costs 1.1 cm (waffle_pi) and 0.8 cm
    # (burger) more than the Dijkstra's, as it did before the heuristic's search was aimed.
    occ = walled(60, 100)
    occ[12:, 48:52] = 100
    start, goal = centre(45, 30, yaw=0.0), centre(45, 70)[:2]
    path = lattice(occ, robot, start, goal, reverse_speed_mps=0.0)
    assert path.cells[:, 0].min() <= 11                   # it went through the opening
    field = lattice_cost_to_come(occ, RES, ORIGIN, robot, start,
                                 LatticeSettings.for_robot(robot, reverse_speed_mps=0.0))
    assert field[45, 70] == pytest.approx(path.cost, rel=1e-6, abs=1e-5)


# ---------------------------------------------------------------- endpoints

def test_endpoint_errors_name_the_endpoint():
    occ = two_rooms(8)
    occ[50, 20] = -1
    settings = LatticeSettings.for_robot(WAFFLE)

    def run(start, goal, goal_yaw=None):
        return plan_lattice(occ, RES, ORIGIN, WAFFLE, start, goal, settings, goal_yaw=goal_yaw)

    with pytest.raises(PlanningError, match=r"start \(10, 39\) is in an obstacle"):
        run(centre(10, 39), centre(30, 70)[:2])           # in the dividing wall
    with pytest.raises(PlanningError, match=r"goal \(10, 40\) is in an obstacle"):
        run(centre(30, 10), centre(10, 40)[:2])
    with pytest.raises(PlanningError, match=r"goal \(30, 90\) is outside the 60 x 80 grid"):
        run(centre(30, 10), centre(30, 90)[:2])
    with pytest.raises(PlanningError, match=r"start \(50, 20\) is in unknown space"):
        run(centre(50, 20), centre(30, 70)[:2])
    # Column 3's centre lies 0.175 m east of the west wall's edge (x = 0.05 m): 0.125 m.
    # Facing west the box reaches 0.0765 m towards it (0.0485 m spare): fits. Facing east its
    # back reaches 0.2045 m towards it, into the wall: collides.
    assert len(run(centre(30, 3, yaw=math.pi), centre(30, 3)[:2]).poses) == 1
    with pytest.raises(PlanningError, match=r"start \(30, 3\) at heading 0 deg: the footprint's box"):
        run(centre(30, 3), centre(30, 20)[:2])
    # Row 1's centre lies 0.025 m from the south wall, less than the box reaches at any heading
    # (0.0765 m ahead, its least reach): no heading fits.
    with pytest.raises(PlanningError, match=r"goal \(1, 10\): no heading fits"):
        run(centre(30, 10), centre(1, 10)[:2])


# ---------------------------------------------------------------- settings

def test_settings_for_robot_and_validation():
    s = LatticeSettings.for_robot(WAFFLE)
    # 0.26 m/s cruise, min(0.8, 1.82) rad/s turning: 0.325 m per radian
    assert s.cruise_speed_mps == 0.26 and s.turn_speed_radps == 0.8
    assert s.turn_cost_m_per_rad == pytest.approx(0.325)
    assert LatticeSettings.for_robot(BURGER, margin_m=0.03).margin_m == 0.03
    for bad in (dict(headings=12), dict(margin_m=0.0), dict(turn_margin_m=-0.01),
                dict(cost_weight=-1.0), dict(turn_speed_radps=-1.0)):
        with pytest.raises(ConfigError, match=next(iter(bad))):
            LatticeSettings(**bad).validate("lattice")
    with pytest.raises(ConfigError, match="margin_m"):
        plan_lattice(two_rooms(8), RES, ORIGIN, WAFFLE, centre(30, 10), centre(30, 70)[:2],
                     LatticeSettings(margin_m=-1.0))
