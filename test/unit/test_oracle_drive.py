"""The oracle's route loop (turtlebot_recon.evaluation.oracle_drive) on two rooms joined by a
door: plan, spin, each point directly or through the known-free stretch of its true path, the
point timeout, re-plans and the end rules."""
import math

import numpy as np
import pytest

from turtlebot_recon.behavior.supervisor import SupervisorSettings
from turtlebot_recon.evaluation.oracle import Oracle, OracleDriverSettings, OracleSettings, Route
from turtlebot_recon.evaluation.oracle_drive import Cancel, DriveTo, OracleDrive, OracleInputs, Turn
from turtlebot_recon.robot import load_robot
from turtlebot_recon.sim import load_world

from conftest import write_world

RES = 0.05
START = (1.0, 1.6)                  # world; the map frame's origin (yaw 0)
SPIN = SupervisorSettings(spin_angle_deg=90.0, spin_speed_radps=0.5)    # pi/2 / 0.5 = 3.14 s
SPIN_S = math.pi


@pytest.fixture(scope="module")
def oracle(tmp_path_factory):
    """Rooms A (x 0.1..4.0) and B (x 4.2..8.2), y 0.1..3.1, a 1 m door at y 1.1..2.1 in the
    0.2 m wall between them (test_oracle.py's world)."""
    free = np.zeros((64, 166), bool)
    free[2:62, 2:80] = True
    free[2:62, 84:164] = True
    free[22:42, 80:84] = True
    path = write_world(tmp_path_factory.mktemp("oracle_drive"), "two_rooms", free, start=[*START, 0.0])
    return Oracle(load_world(path), load_robot("turtlebot3_burger"), 3.5, OracleSettings(restarts=0))


def robot_map(oracle, known_below_x=math.inf):
    """The true map in the robot's map frame, unknown (-1) from world x ``known_below_x`` on."""
    w = oracle.world
    occ = w.occupancy().copy()
    x = w.origin[0] + (np.arange(occ.shape[1]) + 0.5) * RES
    occ[:, x >= known_below_x] = -1
    return occ, (w.origin[0] - START[0], w.origin[1] - START[1])


def inputs(oracle, now_s, active=False, known_below_x=math.inf, truth=START):
    occ, origin = robot_map(oracle, known_below_x)
    return OracleInputs(now_s, truth, occ, RES, origin, active)


def started(oracle, settings, points=None, known_below_x=math.inf):
    """A drive past its plan and spin; ``points`` (world) replace the planned route. Returns
    (drive, the outputs of the tick that ends the spin, its time)."""
    drive = OracleDrive(settings, oracle, SPIN)
    drive.tick(inputs(oracle, 0.0))
    if points is not None:
        drive.route = Route(np.array(points, float), 0.0, 0.0, 0)
    drive.tick(inputs(oracle, 10.0))
    t = 10.0 + SPIN_S
    return drive, drive.tick(inputs(oracle, t, known_below_x=known_below_x)), t


def test_plan_then_spin_then_the_first_point_and_coverage_ends_it(oracle):
    drive = OracleDrive(OracleDriverSettings(), oracle, SPIN)
    out = drive.tick(inputs(oracle, 0.0))
    assert out.actions == [] and out.started_s is None and out.state is None   # planning only
    out = drive.tick(inputs(oracle, 10.0))
    assert out.started_s == 10.0 and out.state == "SPIN" and out.actions == [Turn(0.5)]
    assert drive.tick(inputs(oracle, 10.0 + SPIN_S - 0.05)).actions == [Turn(0.5)]
    out = drive.tick(inputs(oracle, 10.0 + SPIN_S))
    first = np.asarray(drive.route.points[0]) - START          # the map frame: the start is its origin
    # the whole map known: the point shows free, so it is driven to directly
    assert out.state == "EXPLORE" and np.allclose(out.goal, first)
    assert out.actions[0] == Turn(0.0) and len(out.actions) == 2
    assert np.allclose(out.actions[1].xy, first)
    assert drive.tick(inputs(oracle, 13.5, active=True)).actions == []          # still driving
    # the navigator ended the goal; the map covers all of F: done
    out = drive.tick(inputs(oracle, 20.0, active=False))
    assert drive.done and out.state == "DONE" and out.done == "coverage 100.00 % of F"
    assert drive.tick(inputs(oracle, 21.0)).actions == []                       # final


def test_an_unknown_point_is_approached_through_the_known_free_stretch_of_its_true_path(oracle):
    s = OracleDriverSettings(resend_period_s=1.0, advance_m=0.5, point_timeout_s=30.0)
    drive, out, t = started(oracle, s, points=[(6.0, 1.6)], known_below_x=3.0)
    assert np.allclose(out.goal, (5.0, 0.0))
    # the true path runs along y 1.6 through the door; the map is free up to world x 3.0, i.e.
    # map x 2.0: the robot goes to the end of that stretch
    (sent,) = [a for a in out.actions if isinstance(a, DriveTo)]
    assert 1.85 <= sent.xy[0] < 2.0 and abs(sent.xy[1]) < 0.2
    # the map is checked every resend_period_s: not before
    assert drive.tick(inputs(oracle, t + 0.5, active=True, known_below_x=3.9)).actions == []
    # 0.3 m further known: less than advance_m, kept
    assert drive.tick(inputs(oracle, t + 1.0, active=True, known_below_x=3.3)).actions == []
    # 0.8 m further: the nearer point moves on
    (moved,) = drive.tick(inputs(oracle, t + 2.0, active=True, known_below_x=3.8)).actions
    assert 2.65 <= moved.xy[0] < 2.8
    # the navigator ended that goal (it arrived): sent again although the end did not move
    (again,) = drive.tick(inputs(oracle, t + 3.0, active=False, known_below_x=3.8)).actions
    assert again == moved
    # the point itself shows free now: driven to directly
    (direct,) = drive.tick(inputs(oracle, t + 4.0, active=True)).actions
    assert np.allclose(direct.xy, (5.0, 0.0))
    # still active at the point's deadline: cancelled and skipped; the map covers F: done
    assert drive.tick(inputs(oracle, t + 29.9, active=True)).actions == []
    out = drive.tick(inputs(oracle, t + 30.0, active=True))
    assert out.actions == [Cancel()] and out.done == "coverage 100.00 % of F"


def test_a_point_is_driven_to_in_order_then_max_routes_ends_the_run(oracle):
    s = OracleDriverSettings(max_routes=1)
    drive, out, t = started(oracle, s, points=[(2.0, 1.6), (3.0, 1.6)], known_below_x=3.5)
    assert np.allclose(out.actions[-1].xy, (1.0, 0.0))
    # arrived, coverage short of finish_coverage (B unknown): the next point in the same tick
    out = drive.tick(inputs(oracle, t + 5.0, known_below_x=3.5))
    assert np.allclose(out.goal, (2.0, 0.0)) and np.allclose(out.actions[0].xy, (2.0, 0.0))
    out = drive.tick(inputs(oracle, t + 10.0, known_below_x=3.5))
    assert out.done == "1 routes driven"


def test_a_replan_covers_what_is_unseen_and_a_route_without_gain_ends_the_run(oracle):
    drive, out, t = started(oracle, OracleDriverSettings(), points=[(2.0, 1.6)], known_below_x=3.5)
    # the route is done short of finish_coverage: a re-plan from the robot's true position,
    # and the tick ends there (planning takes wall time)
    out = drive.tick(inputs(oracle, t + 5.0, known_below_x=3.5, truth=(2.0, 1.6)))
    assert out.actions == [] and out.done is None and drive.routes == 2
    assert (drive.route.points[:, 0] > 4.2).all()          # only room B is left to see
    out = drive.tick(inputs(oracle, t + 5.1, known_below_x=3.5, truth=(2.0, 1.6)))
    assert np.allclose(out.goal, drive.route.points[0] - START)
    # skip every point of that route (the map never grows): the route added nothing
    while not drive.done:
        t += 1000.0
        out = drive.tick(inputs(oracle, t, active=True, known_below_x=3.5, truth=(2.0, 1.6)))
    assert out.done == "the last route added 0.00 % of F"


def test_a_robot_off_the_costmap_ends_the_run_without_a_route(oracle):
    drive = OracleDrive(OracleDriverSettings(), oracle, SPIN)
    out = drive.tick(inputs(oracle, 0.0, truth=(-3.0, 1.6)))         # off the map
    assert drive.done and out.state == "DONE" and out.done.startswith("no route: ")
