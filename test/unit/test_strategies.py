"""Goal selection: every strategy's pick on hand-made maps, the tour, the GoalBook, parameters.

Maps are small int8 grids at 5 cm (row 0 = smallest y, origin (0, 0) unless stated), the
costmap is the plain one (0 free, 254 occupied, 255 unknown: no inflation, so distances are
easy to work by hand) and the cost-to-come field is the native Dijkstra from the robot.
Frontiers are built here from their cells the way the contract in frontiers.py defines
them. Each expected pick is derived in a comment next to its assertion.
"""
import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from turtlebot_recon.config import ConfigError, load_yaml
from turtlebot_recon.exploration import tour
from turtlebot_recon.exploration.context import Context, Motion
from turtlebot_recon.exploration.frontiers import Frontier, cluster, find_frontier_cells
from turtlebot_recon.exploration.goals import GoalBook, GoalBookSettings, ProgressWatchdog, stands_for
from turtlebot_recon.exploration.strategies import (STRATEGIES, Density, ExploreLite, GainDistanceHeading,
                                                    Nearest, Recon, Sampled, load_strategy, make_strategy)
from turtlebot_recon.planning import dijkstra

TOP = Path(__file__).resolve().parents[2]
RES = 0.05
FREE, OCC, UNK = 0, 100, -1


# ----------------------------------------------------------------------------- factories

def cell_xy(r, c, origin=(0.0, 0.0)):
    return (origin[0] + (c + 0.5) * RES, origin[1] + (r + 0.5) * RES)


# seconds of driving for recon: round numbers (a TurtleBot 3 drives 0.22-0.26 m/s, turns 0.8 rad/s
# in place in the lattice, accelerates 2.5 m/s^2)
MOTION = Motion(cruise_mps=0.25, turn_radps=0.8, accel_mps2=2.5)


def make_ctx(occ, robot_cell, yaw=0.0, now_s=0.0, visits=None, seed=0, priority=(),
             origin=(0.0, 0.0), motion=MOTION):
    """Context with the robot at the centre of ``robot_cell``."""
    occ = np.asarray(occ, dtype=np.int8)
    costmap = np.where(occ < 0, 255, np.where(occ >= 65, 254, 0)).astype(np.uint8)
    field = dijkstra(costmap, robot_cell, resolution=RES)
    return Context(robot_xy=cell_xy(*robot_cell, origin), robot_yaw=yaw, now_s=now_s,
                   resolution=RES, origin=origin, occupancy=occ, costmap=costmap,
                   cost_to_come=field, visits=visits, rng=np.random.default_rng(seed),
                   priority_goals=tuple(priority), motion=motion)


def make_frontier(ctx, cells, id=0, gain=400, goal_cell=None):
    """A Frontier per the contract: goal = the cell nearest the centroid, snapped (1 m)."""
    cells = np.asarray(cells, dtype=np.int32).reshape(-1, 2)
    xy = np.array([ctx.cell_to_xy(c) for c in cells])
    centroid = tuple(xy.mean(axis=0))
    closest = tuple(xy[np.argmin(np.hypot(*(xy - ctx.robot_xy).T))])
    if goal_cell is None:
        rep = cells[np.argmin(np.hypot(*(xy - centroid).T))]
        goal_cell = ctx.snap(ctx.cell_to_xy(rep), 1.0) or (int(rep[0]), int(rep[1]))
    goal_cell = (int(goal_cell[0]), int(goal_cell[1]))
    ok = ctx.goal_ok(goal_cell)
    return Frontier(id=id, cells=cells, size=len(cells), length_m=len(cells) * RES,
                    centroid=(float(centroid[0]), float(centroid[1])),
                    closest=(float(closest[0]), float(closest[1])), goal=ctx.cell_to_xy(goal_cell),
                    goal_cell=goal_cell, gain=gain,
                    path_cost_m=float(ctx.cost_to_come[goal_cell]) if ok else math.inf,
                    reachable=ok)


def column(col, rows):
    return [(r, col) for r in rows]


def detected(ctx, min_size=3):
    """Frontier clusters of ctx.occupancy with the frontier module's own detection steps."""
    clusters = cluster(find_frontier_cells(ctx.occupancy), min_size)
    return [make_frontier(ctx, cells, id=i) for i, cells in enumerate(clusters)]


def assert_valid_goal(f, ctx):
    r, c = f.goal_cell
    assert ctx.costmap[r, c] <= ctx.max_cost and math.isfinite(ctx.cost_to_come[r, c])
    assert f.goal == pytest.approx(ctx.cell_to_xy(f.goal_cell))


# ------------------------------------------------ a near small frontier vs a far large one

@pytest.fixture
def lines():
    """12 x 4 m of free space, robot at cell (40, 10) = (0.525, 2.025), facing +x. Four
    vertical frontier lines (cells listed; the grid stays free so goals sit on them):
      tiny  col  20, rows 33..46: 14 cells = 0.70 m long, closest cell 0.5 m away
      small col  30, rows 32..47: 16 cells = 0.80 m,      closest 1.0 m
      mid   col  50, rows 30..49: 20 cells = 1.00 m,      closest 2.0 m
      large col 210, rows 10..69: 60 cells = 3.00 m,      closest 10.0 m
    """
    ctx = make_ctx(np.zeros((80, 240)), (40, 10))
    spec = [(20, range(33, 47)), (30, range(32, 48)), (50, range(30, 50)), (210, range(10, 70))]
    return ctx, [make_frontier(ctx, column(c, rows), id=i) for i, (c, rows) in enumerate(spec)]


def test_explore_lite_cost_by_hand_and_its_units_bug(lines):
    ctx, fs = lines
    s = ExploreLite()
    # cost = 3.0 * d_min * 0.05 - 1.0 * size * 0.05
    #   tiny  0.15 * 0.5  - 0.70 = -0.625 (but 0.70 m < 0.75 m: never considered)
    #   small 0.15 * 1.0  - 0.80 = -0.65
    #   mid   0.15 * 2.0  - 1.00 = -0.70
    #   large 0.15 * 10.0 - 3.00 = -1.50   <- cheapest: explore_lite drives 10 m
    expected = [-0.625, -0.65, -0.70, -1.50]
    assert [s.cost(f, ctx) for f in fs] == pytest.approx(expected)
    pick = s.choose(fs, ctx, GoalBook())
    assert pick.id == 3
    # its goal is the centroid (10.525, 2.0), snapped to the nearest reachable cell
    assert math.dist(pick.goal, fs[3].centroid) <= RES
    # With the distance in metres (no extra * resolution), 3 d - L would pick the small one:
    # small 3.0 - 0.8 = 2.2 < mid 6.0 - 1.0 = 5.0 < large 30 - 3 = 27.
    fixed = [3.0 * math.dist(ctx.robot_xy, f.closest) - f.length_m for f in fs[1:]]
    assert int(np.argmin(fixed)) == 0


def test_explore_lite_min_frontier_size(lines):
    ctx, fs = lines
    # only the 0.70 m line: too short (< 0.75 m), so nothing to explore
    assert ExploreLite().choose([fs[0]], ctx, GoalBook()) is None
    shorter = ExploreLite(ExploreLite.Settings(min_frontier_size_m=0.7))
    assert shorter.choose([fs[0]], ctx, GoalBook()).id == 0


def test_nearest_takes_the_nearest_accessible_point(lines):
    ctx, fs = lines
    # the tiny line is 0.5 m away: seed 001 has no size filter
    pick = Nearest().choose(fs, ctx, GoalBook())
    assert pick.id == 0 and pick.goal == pytest.approx(fs[0].closest)
    # without it, the small one (1.0 m) - never the large one explore_lite chose
    assert Nearest().choose(fs[1:], ctx, GoalBook()).id == 1


def test_explore_lite_progress_timeout_blacklists_for_good(lines):
    ctx, fs = lines
    s, book = ExploreLite(), GoalBook()
    at = lambda t: dataclasses.replace(ctx, now_s=t)
    assert s.choose(fs, at(0.0), book).id == 3
    assert s.choose(fs, at(30.0), book).id == 3      # 30 s without approach: not yet (> 30)
    # same goal, d_min not smaller for 30.5 s -> centroid blacklisted, next cheapest (mid)
    assert s.choose(fs, at(30.5), book).id == 2
    assert book.is_blacklisted(fs[3].centroid)
    # a success right there later does not bring it back for explore_lite (permanent)...
    book.succeeded(fs[3].centroid, 40.0)
    assert not book.is_blacklisted(fs[3].centroid)            # (expired for the others)
    assert s.choose(fs, at(41.0), book).id == 2
    # ...and approaching the goal counts as progress: the timer restarts
    s2, book2 = ExploreLite(), GoalBook()
    s2.choose(fs, at(0.0), book2)
    nearer = dataclasses.replace(ctx, now_s=29.0, robot_xy=(1.0, 2.025))
    assert s2.choose(fs, nearer, book2).id == 3
    assert s2.choose(fs, dataclasses.replace(nearer, now_s=50.0), book2).id == 3   # 21 s since


# --------------------------------------------------------------- seed 004: heading and gain

@pytest.fixture
def ahead_behind():
    """6 x 4 m free, robot at cell (40, 60) = (3.025, 2.025). Two goals 2.0 m away at
    cells (40, 100) (ahead for yaw 0) and (40, 20) (behind), each with 10 unknown cells in
    its 5 x 5 window: a 2-column strip on its far side, rows 38..42."""
    occ = np.zeros((80, 120), dtype=np.int8)
    occ[38:43, 101:103] = UNK
    occ[38:43, 18:20] = UNK
    ctx = make_ctx(occ, (40, 60))
    ahead = make_frontier(ctx, column(101, range(38, 43)), id=0, goal_cell=(40, 100))
    behind = make_frontier(ctx, column(19, range(38, 43)), id=1, goal_cell=(40, 20))
    return ctx, ahead, behind


def test_gain_distance_heading_prefers_ahead(ahead_behind):
    ctx, ahead, behind = ahead_behind
    s = GainDistanceHeading()
    # ahead:  2.3 * 10 - 2 * 2.0 + 5 * cos(0)  = 23 - 4 + 5 = 24
    # behind: 2.3 * 10 - 2 * 2.0 + 5 * cos(pi) = 23 - 4 - 5 = 14
    assert s.score(ahead, ctx) == pytest.approx(24.0)
    assert s.score(behind, ctx) == pytest.approx(14.0)
    assert s.choose([behind, ahead], ctx, GoalBook()).id == 0
    turned = dataclasses.replace(ctx, robot_yaw=math.pi)
    assert s.choose([behind, ahead], turned, GoalBook()).id == 1


def test_gain_distance_heading_far_rich_beats_near_poor():
    """Robot at (40, 20) facing +x. Near goal (40, 60), 2.0 m, 4 unknowns nearby; far goal
    (40, 140), 6.0 m, 20 unknowns (a 5 x 4 block beyond it)."""
    occ = np.zeros((80, 180), dtype=np.int8)
    occ[40:42, 61:63] = UNK                      # 4 cells in (40, 60)'s window
    occ[38:43, 141:145] = UNK                    # 5 rows x 2 cols in window = 10 ... see below
    occ[38:43, 138:140] = UNK                    # ... + 10 on the near side = 20
    ctx = make_ctx(occ, (40, 20))
    near = make_frontier(ctx, [(40, 61)], id=0, goal_cell=(40, 60))
    far = make_frontier(ctx, [(40, 141)], id=1, goal_cell=(40, 140))
    s = GainDistanceHeading()
    # near: 2.3 * 4 - 2 * 2 + 5 = 10.2; far: 2.3 * 20 - 2 * 6 + 5 = 39.0
    assert s.score(near, ctx) == pytest.approx(10.2)
    assert s.score(far, ctx) == pytest.approx(39.0)
    assert s.choose([near, far], ctx, GoalBook()).id == 1
    assert Nearest().choose([near, far], ctx, GoalBook()).id == 0     # the strategies disagree


# -------------------------------------------------------------------------- seed 003: density

def test_density_frontier_cells_by_hand():
    """Free cols 0..19, unknown cols 20..39, no obstacles: an unknown cell at col c has
    (28 - c) clear columns within 8, times >= 9 rows, so > 5 clear cells up to col 27."""
    occ = np.full((40, 40), UNK, dtype=np.int8)
    occ[:, :20] = FREE
    mask = Density().frontier_cells(occ)
    assert mask[:, 20:28].all() and not mask[:, 28:].any() and not mask[:, :20].any()
    # a blocked cell removes every unknown cell within 8 of it (seed 003's "0 blocked")
    occ[20, 15] = OCC
    mask = Density().frontier_cells(occ)
    assert not mask[12:29, 20:24].any() and mask[11, 20] and mask[29, 20] and mask[20, 24]


def test_density_cost_and_attempt_weight_by_hand():
    occ = np.full((60, 100), UNK, dtype=np.int8)
    occ[:, :60] = FREE
    ctx = make_ctx(occ, (30, 10))
    s = Density()
    cells, cost = s.costs(ctx, GoalBook())
    i = int(np.flatnonzero((cells[:, 0] == 30) & (cells[:, 1] == 60))[0])
    # cell (30, 60): 2.5 m from the robot; frontier band cols 60..67, so its 17 x 17 window
    # holds 8 x 17 = 136 frontier cells, 135 besides itself: 5 * 2.5 - 135 = -122.5
    assert cost[i] == pytest.approx(-122.5)
    assert cells[np.argmin(cost)].tolist() == [30, 60]
    pick = s.choose(detected(ctx), ctx, GoalBook())
    assert pick.goal_cell == (30, 59)            # the unknown cell snapped to free space
    # two failures right there: weight 1 - 2 * 0.2 = 0.6 -> -122.5 / 0.6 = -204.17: the
    # faithful quirk (a negative cost gets MORE attractive); five: floor 0.01
    book = GoalBook(GoalBookSettings(blacklist_after_failures=0))
    for _ in range(2):
        book.failed(cell_xy(30, 60), 0.0)
    assert s.costs(ctx, book)[1][i] == pytest.approx(-122.5 / 0.6)
    for _ in range(3):
        book.failed(cell_xy(30, 60), 0.0)
    assert book.attempt_weight(cell_xy(30, 60)) == pytest.approx(0.01)


def test_density_avoids_frontiers_near_walls_where_nearest_goes():
    """Room cols 11..99 free; col 10 is a wall with a 5-cell door (rows 28..32) onto unknown
    on the left; cols 100.. unknown on the right. Robot at col 30: the door's frontier is
    1.0 m away, the open side 3.5 m. Seed 003 drops unknown cells within 8 of an obstacle,
    so the door has no frontier for it; nearest goes to the door; explore_lite too would
    not (7 cells = 0.35 m < 0.75 m)."""
    occ = np.full((60, 140), UNK, dtype=np.int8)
    occ[:, 11:100] = FREE
    occ[:, 10] = OCC
    occ[28:33, 10] = FREE
    occ[0, 10:100] = OCC
    occ[59, 10:100] = OCC
    ctx = make_ctx(occ, (30, 30))
    fs = detected(ctx)
    door = [f for f in fs if f.centroid[0] < 1.0]
    assert len(door) == 1
    assert Nearest().choose(fs, ctx, GoalBook()).id == door[0].id
    assert Density().choose(fs, ctx, GoalBook()).goal[0] > 4.9
    assert ExploreLite().choose(fs, ctx, GoalBook()).goal[0] > 4.9


# -------------------------------------------------------------------------- seed 000: sampled

@pytest.fixture
def sampled_world():
    """Free cols 0..59, unknown beyond, robot at (30, 10); an obstacle cell at (30, 60)
    splits the frontier column 60 into two clusters: rows 0..29 and rows 31..59."""
    occ = np.full((60, 100), UNK, dtype=np.int8)
    occ[:, :60] = FREE
    occ[30, 60] = OCC
    ctx = make_ctx(occ, (30, 10), seed=7)
    return ctx, detected(ctx)


def test_sampled_is_reproducible_and_follows_the_rule(sampled_world):
    ctx, fs = sampled_world
    cells = np.concatenate([f.cells for f in fs])
    n = len(cells)
    assert len(fs) == 2 and n == 59
    # same seed, same draw: 5 % of 59 cells, rounded up = 3 samples
    picked = np.random.default_rng(7).choice(n, size=math.ceil(0.05 * n), replace=False)
    d = np.array([math.dist(ctx.robot_xy, cell_xy(*cells[i])) for i in picked])
    want = cells[picked[np.argmin(d)]]
    pick = Sampled().choose(fs, ctx, GoalBook())
    assert math.dist(pick.goal, cell_xy(*want)) <= 2 * RES       # that cell, snapped into free
    again = Sampled().choose(fs, dataclasses.replace(ctx, rng=np.random.default_rng(7)), GoalBook())
    assert again.goal == pick.goal
    # median rule: the sample whose distance is nearest the samples' median
    ctx_m = dataclasses.replace(ctx, rng=np.random.default_rng(7))
    med = Sampled(Sampled.Settings(selection="median")).choose(fs, ctx_m, GoalBook())
    want_m = cells[picked[np.argmin(np.abs(d - np.median(d)))]]
    assert math.dist(med.goal, cell_xy(*want_m)) <= 2 * RES
    # different seeds draw different cells (10 seeds, at least 3 different goals)
    goals = {Sampled().choose(fs, dataclasses.replace(ctx, rng=np.random.default_rng(seed)),
                              GoalBook()).goal for seed in range(10)}
    assert len(goals) >= 3


def test_sampled_visits_priority_goals_first(sampled_world):
    ctx, fs = sampled_world
    tag = (1.0, 0.5)
    pick = Sampled().choose(fs, dataclasses.replace(ctx, priority_goals=(tag,)), GoalBook())
    assert pick.id == -1 and math.dist(pick.goal, tag) <= RES
    off = Sampled(Sampled.Settings(priority_goals=False))
    assert off.choose(fs, dataclasses.replace(ctx, priority_goals=(tag,)), GoalBook()).id >= 0


# ------------------------------------------------------------------------------- recon (ours)

@pytest.fixture
def corridor():
    """12 x 1 m corridor (20 x 240 cells), free; robot at cell (10, 60) = (3.025, 0.525),
    facing +x. Frontier lines of 11 cells (rows 5..15, goal at row 10) at the given cols."""
    ctx = make_ctx(np.zeros((20, 240)), (10, 60))

    def at(*cols, gain=400):
        return [make_frontier(ctx, column(c, range(5, 16)), id=i, gain=gain)
                for i, c in enumerate(cols)]
    return ctx, at


def test_recon_tour_goes_to_the_lone_end_first(corridor):
    ctx, at = corridor
    fs = at(0, 110, 160, 200)         # x = 0.025 | 5.525, 8.025, 10.025
    # first legs (s): (3.0 - 0.1 gain) / 0.25 + pi / 0.8 = 15.5 (left, behind) vs 2.4 / 0.25 = 9.6
    # (right). Left first: 15.5 + (5.5 + 2.5 + 2.0) / 0.25 = 55.5; right first: 9.6 + 58 = 67.6
    s = Recon()
    assert s.choose(fs, ctx, GoalBook()).id == 0
    assert [round(x, 3) for x, _ in s.last_tour] == [0.025, 5.525, 8.025, 10.025]
    # nearest and seed 004 go right first and will have to come all the way back
    assert Nearest().choose(fs, ctx, GoalBook()).id == 1
    assert GainDistanceHeading().choose(fs, ctx, GoalBook()).id == 1
    # greedy recon (no tour) takes the least first leg: right
    assert Recon(Recon.Settings(use_tour=False)).choose(fs, ctx, GoalBook()).id == 1


def test_recon_commits_to_its_goal_until_a_map_event(corridor):
    """No cluster born or gone, the pursued one's view the same: the goal is kept and no tour
    is planned, however the costs moved (the robot drove on)."""
    ctx, at = corridor
    up = dataclasses.replace(ctx, robot_yaw=math.pi / 2)     # both sides cost the same turn
    fs = at(20, 104)                                         # x = 1.025 and 5.225
    s, book = Recon(), GoalBook()
    first = s.choose(fs, up, book)             # left 2.0 + 4.2 = 6.2 m < right 2.2 + 4.2 = 6.4 m
    assert first.id == 0 and s.plans == 1
    book.start(first, up)
    c = make_ctx(np.zeros((20, 240)), (10, 80), yaw=math.pi / 2)    # x 4.025: right far better
    same = [make_frontier(c, f.cells, id=f.id) for f in fs]
    assert s.choose(same, c, book).id == 0 and s.plans == 1
    assert Recon().choose(same, c, GoalBook()).id == 1        # a fresh strategy goes right


@pytest.mark.parametrize("col, kept", [(66, True), (80, False)])
def test_recon_keeps_its_goal_unless_a_tour_is_faster_by_more_than_a_switch_costs(corridor, col, kept):
    """At a map event (a third cluster, far right, gone: explored) the tour is planned again.
    Switching from the left goal to the right one costs the turn to face it, (pi/2) / 0.8 =
    1.96 s. Robot at x 3.325 (col 66): left 2.3 + 4.2, right 1.9 + 4.2: right is 0.4 m = 1.6 s
    faster: kept. At x 4.025 (col 80): left 3.0, right 1.2: 7.2 s faster: switched."""
    ctx, at = corridor
    up = dataclasses.replace(ctx, robot_yaw=math.pi / 2)
    fs = at(20, 104, 230)                      # x = 1.025, 5.225, 11.525
    s, book = Recon(), GoalBook()
    first = s.choose(fs, up, book)             # left first: 2.0 + 4.2 + 6.3 < right first
    assert first.id == 0
    book.start(first, up)
    c = make_ctx(np.zeros((20, 240)), (10, col), yaw=math.pi / 2)
    now = [make_frontier(c, f.cells, id=f.id) for f in fs[:2]]
    assert s.choose(now, c, book).id == (0 if kept else 1)
    assert s.plans == 2


@pytest.mark.parametrize("col, side", [(140, "left"), (152, "right")])
def test_recon_tour_outlives_its_first_goal(corridor, col, side):
    """Clusters A (x 3.0), B (x 5.0, twice the gain) and C (x 9.4); the robot at x 6.0 faces
    -x. The tour B, A, C (36.8 s) beats A, B, C (37.2 s). B's frontier is then seen on the way
    (gone) and the robot stands further east. From x 7.0 the last tour's next goal A (15.6 +
    25.6 = 41.2 s) is kept against a fresh tour C first (9.2 + 3.9 s of turning + 25.6 = 38.7 s):
    2.5 s faster, less than the turn to face C (pi / 0.8 = 3.9 s). From x 7.6 the fresh tour
    is 7.3 s faster: taken."""
    up = make_ctx(np.zeros((20, 240)), (10, 120), yaw=math.pi)
    fs = [make_frontier(up, column(c, range(5, 16)), id=i, gain=g)
          for i, (c, g) in enumerate(((60, 400), (100, 800), (188, 400)))]
    s, book = Recon(), GoalBook()
    first = s.choose(fs, up, book)
    assert first.id == 1 and [round(x, 1) for x, _ in s.last_tour] == [5.0, 3.0, 9.4]
    book.start(first, up)
    c = make_ctx(np.zeros((20, 240)), (10, col), yaw=math.pi)
    book.active = None                                   # dropped: its frontier was seen
    rest = [make_frontier(c, f.cells, id=f.id, gain=f.gain) for f in fs if f.id != 1]
    assert s.choose(rest, c, book).id == (0 if side == "left" else 2)
    assert Recon().choose(rest, c, GoalBook()).id == 2   # a fresh tour goes to C first


def test_recon_tour_stays_within_its_cluster_budget_as_the_map_gains_clusters(corridor):
    """tour_max_clusters 4: the first tour holds 4 clusters; four more are born nearer the
    robot (a map event): the next tour holds 4 again, the pursued one among them (2 from the
    last tour, in its order, then the cheapest first legs), not the last tour's 4 plus the 4
    cheapest (a tour kept whole grew with every cluster the map gained: 130 Dijkstras a cycle
    in a large warehouse)."""
    ctx, at = corridor
    s, book = Recon(Recon.Settings(tour_max_clusters=4)), GoalBook()
    first = s.choose(at(10, 20, 200, 220), ctx, book)
    assert len(s.last_tour) == 4 and s.last_tour[0] == first.goal
    book.start(first, ctx)
    s.choose(at(10, 20, 200, 220, 40, 50, 70, 80), ctx, book)
    assert s.plans == 2 and len(s.last_tour) == 4 and first.goal in s.last_tour


def test_recon_switch_cost_grows_with_speed(corridor):
    """Stopping from speed v and getting back to it loses v / a: at 0.25 m/s and 2.5 m/s^2,
    0.1 s; the switch that a standing robot makes by 0.05 s, a moving one does not."""
    ctx, _ = corridor
    fast = dataclasses.replace(MOTION, speed_mps=0.25)
    assert fast.stop_s == pytest.approx(0.1) and MOTION.stop_s == 0.0
    assert fast.stopping_distance_m == pytest.approx(0.25 ** 2 / 5.0)
    assert MOTION.path_s(2.0) == pytest.approx(8.0) and MOTION.turn_s(-math.pi) == pytest.approx(math.pi / 0.8)


def test_recon_uses_path_distance_not_euclidean():
    """4 x 4 m; a wall at row 40 over cols 0..69 (x < 3.5), open at cols 70..79. Robot at
    (30, 20) = (1.025, 1.525). A: goal (50, 20) just above the wall, 1.0 m away in a
    straight line but 5.47 m by path (around the wall's end); B: goal (10, 60), 2.24 m away,
    20 diagonal + 20 straight steps = 2.41 m by path (8-connected)."""
    occ = np.zeros((80, 80), dtype=np.int8)
    occ[40, :70] = OCC
    ctx = make_ctx(occ, (30, 20))
    a = make_frontier(ctx, [(51, 20), (52, 20), (53, 20)], id=0, goal_cell=(50, 20))
    b = make_frontier(ctx, [(9, 60), (8, 60), (7, 60)], id=1, goal_cell=(10, 60))
    assert a.path_cost_m > 5.0
    assert b.path_cost_m == pytest.approx(20 * RES * math.sqrt(2) + 20 * RES)
    assert Nearest().choose([a, b], ctx, GoalBook()).id == 0
    assert Recon().choose([a, b], ctx, GoalBook()).id == 1


def test_recon_first_leg_by_hand_and_visits(corridor):
    ctx, at = corridor
    left, right = at(20, 100)                  # 2.0 m behind, 2.0 m ahead
    visits = np.zeros((20, 240), dtype=np.int32)
    visits[10, 95:100] = 3                     # 3 passes within 0.5 m of the right goal
    v = dataclasses.replace(ctx, robot_yaw=math.pi / 2, visits=visits)
    s = Recon()
    # seconds: (2.0 m + 0.5 m * 3 passes - 0.1 m/m^2 * 400 * 0.0025 m^2) / 0.25 m/s
    #          + (pi/2 rad) / 0.8 rad/s
    assert s.first_leg(right, v) == pytest.approx((2.0 + 1.5 - 0.1) / 0.25 + math.pi / 2 / 0.8)
    assert s.first_leg(left, v) == pytest.approx((2.0 - 0.1) / 0.25 + math.pi / 2 / 0.8)
    assert Recon().choose([right, left], v, GoalBook()).id == 0    # the unvisited side


def test_recon_takes_small_frontiers_on_the_way(corridor):
    ctx, at = corridor
    poor = at(80, gain=10)[0]                  # 10 cells = 0.025 m^2, 1 m ahead
    rich = dataclasses.replace(at(200)[0], id=1)   # 400 cells = 1 m^2, 7 m ahead
    # poor first: 1.0 + 6.0 = 7.0 m of tour; rich first: 6.9 + 6.0 = 12.9 m. A small
    # frontier is not kept for later (a dead end's last cells, a long way back at the end).
    # (A goal reached without revealing its frontier is not recon's business: the frontier
    # search gives that frontier another viewpoint, or gives it up; test_frontiers.)
    assert Recon().choose([poor, rich], ctx, GoalBook()).id == 0


# ----------------------------------------------------- every strategy: only valid goals

@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_no_strategy_returns_a_goal_without_a_plan_or_in_lethal_cost(name):
    """Free cols 0..59 (unknown beyond), robot at (40, 15). A sealed room in the corner
    (walls rows 52..99, cols 0..50) holds an unknown patch at rows 78..82, cols 23..27: its
    frontier is 1.9 m away (the open side's 2.25 m) but has no path, and no reachable cell
    is within 1 m of it. A tag seen inside it has no path either. A third frontier is
    'reachable' by its stale flag, but its goal cell (6, 39) has just become lethal."""
    occ = np.full((100, 100), UNK, dtype=np.int8)
    occ[:, :60] = FREE
    occ[52:100, 0:51] = OCC
    occ[54:100, 2:49] = FREE
    occ[78:83, 23:28] = UNK
    ctx = make_ctx(occ, (40, 15), priority=((1.25, 4.0),))
    fs = detected(ctx)
    sealed = [f for f in fs if f.centroid[1] > 3.0 and f.centroid[0] < 2.5]
    assert len(sealed) == 1 and not sealed[0].reachable
    assert math.dist(ctx.robot_xy, sealed[0].closest) < 2.25 - 0.2
    stale = make_frontier(ctx, [(5, 40), (6, 40), (7, 40)], id=len(fs), goal_cell=(6, 39))
    ctx.costmap[6, 39] = 254
    # and one the frontier search flagged unreachable (behind a gap narrower than the
    # robot, which this plain costmap cannot show): free cells lie right next to it
    gap = dataclasses.replace(make_frontier(ctx, column(30, range(38, 43)), id=len(fs) + 1),
                              reachable=False, path_cost_m=math.inf)
    ctx = dataclasses.replace(ctx)              # forget the cached reachable mask
    pick = make_strategy(name, {}).choose(fs + [stale, gap], ctx, GoalBook())
    assert pick is not None and pick.id not in (sealed[0].id, gap.id)
    assert pick.goal_cell != (6, 39)
    assert_valid_goal(pick, ctx)


@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_every_strategy_respects_the_blacklist_and_returns_none_when_done(name, sampled_world):
    ctx, fs = sampled_world
    s = make_strategy(name, {})
    assert s.choose([], ctx, GoalBook()) is None
    book = GoalBook(GoalBookSettings(blacklist_radius_m=0.6))
    first = s.choose(fs, ctx, book)
    book.blacklist(first.goal, 0.0)
    second = make_strategy(name, {}).choose(fs, ctx, book)
    assert second is None or math.dist(second.goal, first.goal) > 0.6


# ----------------------------------------------------------------------------------- tour

def test_tour_line_in_order_not_zigzag():
    pts = [(3.0, 0.0), (1.0, 0.0), (4.0, 0.0), (2.0, 0.0), (5.0, 0.0)]
    assert tour.order((0.0, 0.0), pts) == [1, 3, 0, 2, 4]         # x = 1, 2, 3, 4, 5
    # open path: the start is not revisited, so the short side goes first
    # (-1 first: 1 + 2 + 1 + 1 = 5; 1 first: 1 + 1 + 1 + 4 = 7)
    assert tour.order((0.0, 0.0), [(1.0, 0.0), (-1.0, 0.0), (2.0, 0.0), (3.0, 0.0)]) == [1, 0, 2, 3]


def test_two_opt_removes_a_zigzag_and_crossings():
    xs = [0.0, 1.0, 3.0, 2.0, 4.0]             # start, then x = 1, 3, 2, 4: 1 + 2 + 1 + 2 = 6
    nodes = [(x, 0.0) for x in xs]
    D = tour.distance_matrix(nodes[0], nodes[1:])
    assert tour.length(D, [0, 1, 2, 3, 4]) == pytest.approx(6.0)
    # nearest insertion on a line appends at the open end each time: 1 + 1 + 1 + 1
    assert tour.nearest_insertion(D) == [0, 1, 3, 2, 4]       # nodes at x = 1, 2, 3, 4
    better = tour.two_opt(D, [0, 1, 2, 3, 4])
    assert better == [0, 1, 3, 2, 4] and tour.length(D, better) == pytest.approx(4.0)
    # random points, the identity order (full of crossings): 2-opt leaves no two legs crossing
    rng = np.random.default_rng(3)
    for _ in range(20):
        pts = [tuple(p) for p in rng.uniform(0, 10, size=(12, 2))]
        D = tour.prepare(tour.distance_matrix((5.0, 5.0), pts))
        t = tour.two_opt(D, list(range(13)))
        path = [(5.0, 5.0)] + pts
        segs = [(path[a], path[b]) for a, b in zip(t[:-1], t[1:])]
        for (p, q), (u, w) in itertools.combinations(segs, 2):
            assert not _cross(p, q, u, w)


def _cross(p, q, u, w):
    """Proper intersection of segments pq and uw (shared end points do not count)."""
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    if {p, q} & {u, w}:
        return False
    return orient(p, q, u) * orient(p, q, w) < 0 and orient(u, w, p) * orient(u, w, q) < 0


def test_tour_never_longer_than_nearest_neighbour():
    rng = np.random.default_rng(11)
    for n in (2, 5, 10, 30, 60):
        pts = [tuple(p) for p in rng.uniform(0, 20, size=(n, 2))]
        D = tour.prepare(tour.distance_matrix((0.0, 0.0), pts))
        got = [0] + [i + 1 for i in tour.order((0.0, 0.0), pts)]
        assert sorted(got) == list(range(n + 1))
        assert tour.length(D, got) <= tour.length(D, tour.nearest_neighbour(D)) + 1e-9


def test_tour_accepts_a_matrix_or_a_callable():
    pts = [(2.0, 0.0), (1.0, 0.0), (3.0, 0.0)]
    manhattan = lambda a, b: abs(a[0] - b[0]) + abs(a[1] - b[1])
    assert tour.order((0.0, 0.0), pts, manhattan) == [1, 0, 2]
    D = tour.distance_matrix((0.0, 0.0), pts)
    assert tour.order((0.0, 0.0), pts, D) == [1, 0, 2]
    with pytest.raises(ValueError, match="start at index 0"):
        tour.order((0.0, 0.0), pts, D[1:, 1:])
    assert tour.order((0.0, 0.0), []) == []


def test_path_distance_matrix_follows_walls():
    occ = np.zeros((80, 80), dtype=np.int8)
    occ[40, :70] = OCC
    ctx = make_ctx(occ, (30, 20))
    goals = [(50, 20), (10, 60)]
    D = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come, goals, RES)
    assert D[0, 1] == pytest.approx(ctx.cost_to_come[50, 20])
    assert D[1, 2] == pytest.approx(dijkstra(ctx.costmap, (50, 20), resolution=RES)[10, 60])
    assert D[1, 2] > math.dist(cell_xy(50, 20), cell_xy(10, 60)) + 1.0     # around the wall
    assert D[1, 2] == D[2, 1]                                 # one run, mirrored


def test_path_distance_matrix_matches_full_dijkstra_runs():
    rng = np.random.default_rng(7)
    occ = np.where(rng.random((60, 70)) < 0.08, OCC, 0).astype(np.int8)
    occ[30, 5:65] = OCC
    ctx = make_ctx(occ, (5, 5))
    free = np.argwhere(np.isfinite(ctx.cost_to_come) & (ctx.costmap < 200))
    goals = [tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 8, replace=False)]
    D = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come, goals, RES)
    for i, g in enumerate(goals):
        full = dijkstra(ctx.costmap, g, resolution=RES)
        for j in range(i + 1, len(goals)):
            assert D[i + 1, j + 1] == D[j + 1, i + 1] == pytest.approx(full[goals[j]], rel=1e-6)


def test_path_distance_matrix_on_coarser_cells():
    occ = np.zeros((80, 80), dtype=np.int8)
    occ[39:42, :70] = OCC              # 3 cells: the robot's inflated costmap has 7+ at any wall
    ctx = make_ctx(occ, (30, 20))
    goals = [(50, 20), (10, 60), (70, 70)]
    fine = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come, goals, RES)
    coarse = tour.path_distance_matrix(ctx.costmap, ctx.cost_to_come, goals, RES, cell_factor=2)
    np.testing.assert_array_equal(coarse[0], fine[0])                 # the robot's row: its own field
    np.testing.assert_allclose(coarse[1:, 1:], fine[1:, 1:], rtol=0.05, atol=2 * 2 * RES)
    assert coarse[1, 2] > math.dist(cell_xy(50, 20), cell_xy(10, 60)) + 1.0   # still around the wall


def test_coarsen_keeps_one_cell_doors_and_closes_thick_walls():
    costmap = np.zeros((20, 20), dtype=np.uint8)
    costmap[9, :] = 254
    costmap[9, 7] = 0                                                 # a door one fine cell wide
    door = tour.coarsen(costmap, 2)
    assert door.shape == (10, 10) and np.isfinite(dijkstra(door, (0, 0), resolution=0.1)[9, 9])
    costmap[8:11, :] = 254                                            # 3 cells thick, no door
    assert np.isinf(dijkstra(tour.coarsen(costmap, 2), (0, 0), resolution=0.1)[9, 9])
    odd = tour.coarsen(np.zeros((5, 7), dtype=np.uint8), 2)           # the edge: unknown padding
    assert odd.shape == (3, 4) and odd.max() == 0
    assert tour.coarsen(costmap, 1) is costmap


# ------------------------------------------------------------------------------- GoalBook

def test_goal_book_attempts_failures_and_blacklist_radius():
    book = GoalBook(GoalBookSettings(attempt_radius_m=0.4, blacklist_radius_m=0.5,
                                     blacklist_after_failures=2))
    ctx = make_ctx(np.zeros((10, 10)), (5, 5))
    f = make_frontier(ctx, [(1, 1)], goal_cell=(2, 2))
    book.start(f, ctx)
    book.start(dataclasses.replace(f, goal=(f.goal[0] + 0.3, f.goal[1])), ctx)   # same goal
    book.start(dataclasses.replace(f, goal=(f.goal[0] + 1.0, f.goal[1])), ctx)   # another
    assert book.attempts(f.goal) == 2
    assert book.failed((1.0, 1.0), 5.0) is False          # one failure: not yet (2 needed)
    assert book.failed((1.2, 1.0), 6.0) is True           # second within 0.4 m: blacklisted
    assert book.is_blacklisted((1.2 + 0.49, 1.0)) and not book.is_blacklisted((1.2 + 0.51, 1.0))
    # explore_lite's square: |dx|, |dy| < 0.25
    assert book.is_blacklisted((1.44, 1.2), 0.25, chebyshev=True)
    assert not book.is_blacklisted((1.46, 1.0), 0.25, chebyshev=True)


def test_goal_book_an_obstacle_at_a_goal_blacklists_it_the_second_time_on_that_cell():
    book = GoalBook(GoalBookSettings(attempt_radius_m=0.4, blacklist_radius_m=0.5,
                                     blacklist_after_failures=1))
    ctx = make_ctx(np.zeros((10, 10)), (5, 5))
    f = make_frontier(ctx, [(1, 1)], goal_cell=(2, 2))
    book.start(f, ctx)
    assert book.obstructed(f.goal, 1.0, 0.05) is False    # the map grew: choose again
    assert book.active is None and book.failures(f.goal) == 0 and not book.is_blacklisted(f.goal)
    # the wall band firmed up: the frontier's next goal lies two cells further out, blocked
    # too as the band grows again: still the map growing, not a failure
    near = (f.goal[0] + 0.1, f.goal[1])
    book.start(dataclasses.replace(f, goal=near), ctx)
    assert book.obstructed(near, 2.0, 0.05) is False
    assert book.failures(f.goal) == 0 and not book.is_blacklisted(near)
    # back on the first cell (it read free again from afar): a shuttle, blacklisted
    again = (f.goal[0] + 0.04, f.goal[1])
    book.start(dataclasses.replace(f, goal=again), ctx)
    assert book.obstructed(again, 3.0, 0.05) is True
    assert book.is_blacklisted(f.goal) and book.active is None


def test_a_sent_goal_stands_for_a_choice_near_it_only_while_it_is_still_a_goal():
    occ = np.zeros((20, 20), np.int8)
    ctx = make_ctx(occ, (5, 5))
    sent = ctx.cell_to_xy((10, 10))
    assert stands_for(sent, ctx.cell_to_xy((10, 14)), 0.3, ctx)       # 0.2 m: on its way
    assert not stands_for(sent, ctx.cell_to_xy((10, 17)), 0.3, ctx)   # 0.35 m: another goal
    occ[10, 10] = 100                                                  # a wall cell appeared
    blocked = make_ctx(occ, (5, 5))
    assert not stands_for(sent, ctx.cell_to_xy((10, 14)), 0.3, blocked)


def test_goal_book_tried_holds_the_successes_before_now():
    book = GoalBook(GoalBookSettings(attempt_radius_m=0.4))
    assert book.tried(0.0).reached.shape == (0, 2)
    book.blacklist((5.0, 5.0), 0.0)            # a failure is the navigator's verdict: not tried
    book.succeeded((0.5, 0.0), 2.0)
    # the cycle the arrival triggers (same time) runs on the map from before it: not yet
    assert book.tried(2.0).reached.shape == (0, 2)
    tried = book.tried(2.1)
    assert tried.reached.tolist() == [[0.5, 0.0]] and tried.radius_m == 0.4
    assert tried.covers((0.9, 0.0)) and not tried.covers((0.95, 0.0))
    assert not tried.covers((5.0, 5.0))


def test_goal_book_success_expires_nearby_entries_unless_permanent():
    for permanent in (False, True):
        book = GoalBook(GoalBookSettings(expire_radius_m=1.0, permanent_blacklist=permanent))
        book.blacklist((0.0, 0.0), 10.0)
        book.blacklist((5.0, 0.0), 10.0)
        book.succeeded((0.0, 0.5), 9.0)               # earlier than the entry: no effect
        assert book.is_blacklisted((0.0, 0.0))
        expired = book.succeeded((0.0, 0.9), 20.0)    # later, 0.9 m away: expires the first
        assert book.is_blacklisted((0.0, 0.0)) is permanent
        assert expired == (0 if permanent else 1)
        assert book.is_blacklisted((5.0, 0.0))        # 5 m away: untouched
        assert book.is_blacklisted((0.0, 0.0), include_expired=True)


def test_progress_watchdog():
    w = ProgressWatchdog(timeout_s=10.0, min_progress_m=0.05)
    assert not w.update((1.0, 0.0), 5.0, 0.0)
    assert not w.update((1.0, 0.0), 4.97, 9.0)   # 3 cm: not progress
    assert w.update((1.0, 0.0), 4.97, 10.5)      # 10.5 s since the last progress
    assert not w.update((2.0, 0.0), 6.0, 11.0)   # a new goal restarts it
    assert not w.update((2.0, 0.0), 5.9, 20.0)   # 10 cm closer: progress at 20 s
    assert not w.update((2.0, 0.0), 5.9, 30.0) and w.update((2.0, 0.0), 5.9, 30.1)
    book = GoalBook(GoalBookSettings(progress_timeout_s=30.0))
    assert not book.stalled(1.0, 100.0)          # no active goal: never stalled


def test_reevaluate_when_the_frontier_was_explored_on_the_way():
    occ = np.full((60, 100), UNK, dtype=np.int8)
    occ[:, :60] = FREE
    ctx = make_ctx(occ, (30, 10))
    target = make_frontier(ctx, column(60, range(20, 41)), goal_cell=(30, 59))
    book = GoalBook()
    active = book.start(target, ctx)
    assert book.reevaluate_reason(active, [target], ctx) is None
    # the map grew by 1 m on the left and bottom (origin -1, -1): same place, other cells
    grown_occ = np.full((80, 120), UNK, dtype=np.int8)
    grown_occ[20:, 20:80] = FREE
    grown = make_ctx(grown_occ, (50, 30), origin=(-1.0, -1.0))
    moved = make_frontier(grown, column(80, range(40, 61)), goal_cell=(50, 79))
    assert book.reevaluate_reason(active, [moved], grown) is None
    # seen from the way: only rows 20..21 are left; old cells within 0.15 m (3 cells) of
    # them are rows 20..24, 5 of 21 = 24 % < 25 % -> explored
    part = make_frontier(ctx, column(60, range(20, 22)), goal_cell=(21, 59))
    assert book.reevaluate_reason(active, [part], ctx) == "explored"
    # rows 20..22 left: old rows 20..25 remain, 6 of 21 = 29 %: keep going
    more = make_frontier(ctx, column(60, range(20, 23)))
    assert book.reevaluate_reason(active, [more], ctx) is None
    # gone entirely, only a frontier elsewhere
    far = make_frontier(ctx, column(60, range(50, 55)))
    assert book.should_reevaluate(active, [far], ctx)
    # an obstacle appears at the goal (seed 000's goal reset); the goal is walled in
    blocked = make_ctx(np.where(np.arange(100)[None, :] == 59, OCC, occ).astype(np.int8), (30, 10))
    assert book.reevaluate_reason(active, [target], blocked) == "blocked"
    walled = occ.copy()
    walled[:, 40] = OCC
    assert book.reevaluate_reason(active, [target], make_ctx(walled, (30, 10))) == "no path"
    # success clears the active goal
    book.succeeded(active.goal, 5.0)
    assert book.active is None


# ------------------------------------------------------------------------------ parameters

def test_make_strategy_validates_parameters():
    with pytest.raises(ConfigError,
                       match=r"strategies/recon: unknown parameter\(s\) \['gain_weight'\]"):
        make_strategy("recon", {"gain_weight": 1.0})
    with pytest.raises(ConfigError,
                       match="strategies/sampled/selection: must be 'nearest' or 'median'"):
        make_strategy("sampled", {"selection": "mean"})
    with pytest.raises(ConfigError,
                       match="strategies/explore_lite/potential_scale: expected a number"):
        make_strategy("explore_lite", {"potential_scale": "high"})
    with pytest.raises(ConfigError, match="unknown strategy 'frontier'"):
        make_strategy("frontier", {})
    with pytest.raises(ConfigError, match=r"explorer/goals: unknown parameter\(s\) \['radius'\]"):
        load_strategy({"strategy": "recon", "goals": {"radius": 1.0}})
    with pytest.raises(ConfigError, match=r"unknown strategy block\(s\) \['nearst'\]"):
        load_strategy({"strategy": "nearest", "strategies": {"nearst": {}}})
    # a typo in a block that is not chosen still fails
    with pytest.raises(ConfigError, match="strategies/density"):
        load_strategy({"strategy": "recon", "strategies": {"density": {"distance_weight": 5}}})
    s = make_strategy("density", {"distance_weight_per_m": 4})
    assert s.settings.distance_weight_per_m == 4.0 and s.name == "density"


def test_load_strategy_reads_explorer_yaml():
    # its keys and defaults block by block: test_config's table
    data = load_yaml(TOP / "config" / "explorer.yaml")
    strategy, goals = load_strategy(data)
    assert isinstance(strategy, Recon) and goals == GoalBookSettings()
