"""iLQR tracking for the unicycle (include/turtlebot_recon/ilqr.hpp, bound as ilqr_track): it
lowers the tracking cost of a perturbed start, its gains stabilise the nominal trajectory, its
controls keep their bounds and its states are the motion model's rollout of its controls."""
from functools import partial

import numpy as np
import pytest

from turtlebot_recon import _native

DT = 0.05           # s, MPPI's step (56 steps: 2.8 s)
T = 56
WAFFLE = dict(u_min=[-0.26, -1.82], u_max=[0.26, 1.82])   # the waffle_pi's limits (m/s, rad/s)
WIDE = dict(u_min=[-1.0, -2.0], u_max=[1.0, 2.0])         # an idealised unicycle's
# the binding takes every weight: these (the diagonals of Q, R, Qf, S) unless a test gives its own
ilqr_track = partial(_native.ilqr_track, q=[1.0, 1.0, 0.1], r=[0.1, 0.01], qf=[10.0, 10.0, 1.0],
                     r_change=[0.0, 0.0], max_iterations=10)


def rollout(x0, u, dt=DT):
    """The discrete unicycle of seed 000, written out: x + dt (v cos yaw, v sin yaw, w)."""
    x = np.zeros((len(u) + 1, 3))
    x[0] = x0
    for t, (v, w) in enumerate(u):
        x[t + 1] = x[t] + dt * np.array([v * np.cos(x[t, 2]), v * np.sin(x[t, 2]), w])
    return x


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def arc_reference(v=0.5, w=0.4):
    u = np.tile([v, w], (T, 1))
    return rollout([0.0, 0.0, 0.0], u), u


def test_the_tracking_cost_falls_from_a_perturbed_start():
    x_ref, u_ref = arc_reference()
    x0 = np.array([0.15, -0.1, 0.3])        # 18 cm and 17 deg off the reference's start
    r = ilqr_track(x0, x_ref, u_ref, dt=DT, **WIDE)
    cost = r.cost_history
    assert len(cost) >= 3 and (np.diff(cost) < 0).all()           # every accepted step lowers it
    # open loop (the reference's own controls) from x0 costs at least the start's error each step
    # (about 0.18^2 x 2 + 0.3^2 x 0.1 = 0.074 per step): iLQR pulls the robot onto the reference
    assert cost[-1] < 0.3 * cost[0]
    err = r.states[-1] - x_ref[-1]
    assert np.hypot(err[0], err[1]) < 0.01 and abs(wrap(err[2])) < 0.02
    assert r.converged and r.iterations <= 10


def test_states_are_the_motion_models_rollout_of_the_controls():
    x_ref, u_ref = arc_reference()
    r = ilqr_track([0.1, 0.1, -0.2], x_ref, u_ref, dt=DT, **WIDE)
    assert r.states.shape == (T + 1, 3) and r.controls.shape == (T, 2) and r.gains.shape == (T, 2, 3)
    np.testing.assert_allclose(r.states, rollout([0.1, 0.1, -0.2], r.controls), atol=1e-12)


def test_on_the_reference_nothing_changes():
    x_ref, u_ref = arc_reference()
    r = ilqr_track(x_ref[0], x_ref, u_ref, dt=DT, **WIDE)
    assert r.cost_history[0] == pytest.approx(0.0, abs=1e-20)
    np.testing.assert_allclose(r.controls, u_ref, atol=1e-12)


@pytest.mark.parametrize("offset", [(0.2, 0.0, 0.0), (0.0, -0.2, 0.0), (0.0, 0.0, 0.5), (-0.1, 0.15, -0.4)])
def test_the_gains_stabilise_the_nominal_trajectory(offset):
    """u = u_ref + K_t (x - x_ref) from a start off the reference converges back onto it; the
    reference's own controls (open loop) keep the offset or worsen it."""
    x_ref, u_ref = arc_reference()
    gains = ilqr_track(x_ref[0], x_ref, u_ref, dt=DT, **WIDE).gains
    x = x_ref[0] + np.array(offset)
    x_open = x.copy()
    for t in range(T):
        dx = x - x_ref[t]
        dx[2] = wrap(dx[2])
        v, w = np.clip(u_ref[t] + gains[t] @ dx, WIDE["u_min"], WIDE["u_max"])
        x = x + DT * np.array([v * np.cos(x[2]), v * np.sin(x[2]), w])
        v, w = u_ref[t]
        x_open = x_open + DT * np.array([v * np.cos(x_open[2]), v * np.sin(x_open[2]), w])
    start = np.linalg.norm(offset)
    closed = np.hypot(*(x - x_ref[-1])[:2]) + abs(wrap(x[2] - x_ref[-1, 2]))
    opened = np.hypot(*(x_open - x_ref[-1])[:2]) + abs(wrap(x_open[2] - x_ref[-1, 2]))
    assert closed < 0.2 * start
    assert opened > 0.5 * start


def test_controls_keep_the_robots_limits():
    """A reference at 0.25 m/s started 0.3 m behind: catching up needs more than the waffle_pi's
    0.26 m/s, so v sits on its bound for a while and never beyond it."""
    x_ref, u_ref = arc_reference(v=0.25, w=1.0)
    r = ilqr_track([-0.3, 0.0, 0.0], x_ref, u_ref, dt=DT, **WAFFLE)
    lo, hi = np.array(WAFFLE["u_min"]), np.array(WAFFLE["u_max"])
    assert (r.controls >= lo - 1e-12).all() and (r.controls <= hi + 1e-12).all()
    assert (np.isclose(r.controls[:, 0], hi[0])).sum() >= 5
    assert (np.diff(r.cost_history) < 0).all()
    # an initial guess outside the bounds is clamped first
    r = ilqr_track([-0.3, 0.0, 0.0], x_ref, u_ref, u_init=np.tile([5.0, -9.0], (T, 1)),
                           dt=DT, **WAFFLE)
    assert (r.controls >= lo - 1e-12).all() and (r.controls <= hi + 1e-12).all()


def test_the_yaw_error_is_wrapped():
    """A reference heading of pi and a start at -pi + 0.1: 0.1 rad apart, not 2 pi - 0.1."""
    u_ref = np.tile([0.3, 0.0], (T, 1))
    x_ref = rollout([0.0, 0.0, np.pi], u_ref)
    r = ilqr_track([0.0, 0.0, -np.pi + 0.1], x_ref, u_ref, dt=DT, **WIDE)
    assert np.abs(r.controls[:, 1]).max() < 1.0          # no turn the long way round
    assert abs(wrap(r.states[-1, 2] - np.pi)) < 0.02


def full_cost(x0, u, x_ref, u_ref, q, r, qf, r_change, u_prev):
    """ilqr.hpp's J written out: tracking, control, change of the command (from u_prev), terminal."""
    x = rollout(x0, u)
    e = x - x_ref
    e[:, 2] = wrap(e[:, 2])
    change = np.diff(np.vstack([u_prev, u]), axis=0)
    return float((e[:-1] ** 2 @ np.asarray(q)).sum() + ((u - u_ref) ** 2 @ np.asarray(r)).sum()
                 + (change ** 2 @ np.asarray(r_change)).sum() + e[-1] ** 2 @ np.asarray(qf))


def test_the_change_cost_smooths_the_command_and_is_minimised():
    """With a cost on u_t - u_{t-1} (from the command before, u_prev), the controls change less,
    the first one stays nearer u_prev, and the result is a minimum of the whole cost: no small
    step of any one control lowers it (the augmented backward pass is right)."""
    x_ref, u_ref = arc_reference()
    x0 = np.array([0.15, -0.1, 0.3])
    u_prev = np.array([0.0, -1.0])                  # the robot was turning the other way
    weights = dict(q=[5.0, 5.0, 1.0], r=[1.0, 0.1], qf=[50.0, 50.0, 10.0])
    plain = ilqr_track(x0, x_ref, u_ref, dt=DT, u_prev=u_prev, **weights, **WIDE)
    smooth = ilqr_track(x0, x_ref, u_ref, dt=DT, u_prev=u_prev, r_change=[20.0, 2.0],
                                max_iterations=50, **weights, **WIDE)
    change = lambda u: np.diff(np.vstack([u_prev, u]), axis=0)             # noqa: E731
    assert ((change(smooth.controls) ** 2).sum(axis=0) < 0.5 * (change(plain.controls) ** 2).sum(axis=0)).all()
    assert (np.abs(change(smooth.controls)).max(axis=0) < 0.5 * np.abs(change(plain.controls)).max(axis=0)).all()
    assert np.linalg.norm(smooth.controls[0] - u_prev) < 0.7 * np.linalg.norm(plain.controls[0] - u_prev)
    args = (x0, x_ref, u_ref, weights["q"], weights["r"], weights["qf"], [20.0, 2.0], u_prev)
    best = full_cost(x0, smooth.controls, *args[1:])
    assert best == pytest.approx(smooth.cost_history[-1], rel=1e-9)
    for t in (0, 1, T // 2, T - 1):
        for j in (0, 1):
            for eps in (-1e-3, 1e-3):
                u = smooth.controls.copy()
                u[t, j] += eps
                assert full_cost(x0, u, *args[1:]) > best - 1e-9
    # without u_prev the first control has no change cost: it equals the plain solution's start
    # more closely than with it
    free = ilqr_track(x0, x_ref, u_ref, dt=DT, r_change=[20.0, 2.0], max_iterations=50,
                              **weights, **WIDE)
    assert np.linalg.norm(free.controls[0] - u_prev) > np.linalg.norm(smooth.controls[0] - u_prev)


@pytest.mark.parametrize("kwargs, message", [
    (dict(x0=[0.0, 0.0]), "x0 must be"),
    (dict(x0=[0.0, np.nan, 0.0]), "x0 must be finite"),
    (dict(x_ref=np.zeros((T, 3))), r"x_ref must be an \(57, 3\) array"),
    (dict(u_ref=np.zeros((0, 2))), "u_ref must be a"),
    (dict(u_init=np.full((T, 2), np.nan)), "u_init must be finite"),
    (dict(dt=0.0), "dt must be > 0"),
    (dict(q=[1.0, -1.0, 0.0]), "q must be finite and >= 0"),
    (dict(r_change=[1.0, np.inf]), "r_change must be finite and >= 0"),
    (dict(u_prev=[0.0, np.nan]), "u_prev must be finite"),
    (dict(u_min=[1.0, -1.0], u_max=[0.0, 1.0]), "u_min must be <= u_max"),
])
def test_bad_arguments_raise_one_line(kwargs, message):
    x_ref, u_ref = arc_reference()
    args = {**dict(x0=[0.0, 0.0, 0.0], x_ref=x_ref, u_ref=u_ref, dt=DT), **kwargs}
    with pytest.raises(ValueError, match="ilqr_track: " + message):
        ilqr_track(**{**WIDE, **args})
