"""Tube MPPI (seed 000's Algorithm 2): MPPI plans the nominal system, iLQR keeps the real one on it.

One control step, ``TubeMppiController.compute(ControlInput) -> ControlOutput``:

1. checks     the MPPI controller's own (control.mppi): path, map, finite pose and velocity,
              the robot's and the goal's cells, the goal tolerance and the final turn in place
              (the shared tracking.PathTracker).
2. tube       the nominal state z (noise free, kept between steps) is reset to the measured
              state x when x has left the tube: |xy - z_xy| > ``tube_radius_m`` or
              |yaw - z_yaw| > ``tube_yaw_rad`` (and on the first step, after a reset or a stop).
3. nominal    one MPPI iteration from z (not from x): nominal controls v_0..v_{T-1} and
              states z_0..z_T (``MppiController.optimize``'s path).
4. ancillary  iLQR (``_native.ilqr_track``, include/turtlebot_recon/ilqr.hpp) from x tracking
              (z_t, v_t) with the quadratic cost of ``q_*``, ``r_*``, ``qf_*`` and ``r_change_*``
              (on the change of the command from the one before) within the robot's velocity
              limits; its first control is the command, capped by the acceleration limits from
              the measured velocity.
5. safety     the MPPI controller's checks on the ancillary's predicted trajectory from x: every
              rollout in collision, the exact body check of its first ``check_horizon_s``, a
              stall: zero command, "blocked", one line why.
6. advance    z <- z(period): the nominal state one control period (round(period /
              model_dt_s) model steps) along its own trajectory, its speeds the nominal
              control there.

The MPPI parameters are config/mppi.yaml's (``MppiSettings``); this module's are
config/tube_mppi.yaml's (``TubeMppiSettings``). iLQR's cost per model step:
  (x_t - z_t)' diag(q_xy, q_xy, q_yaw) (x_t - z_t) + (u_t - v_t)' diag(r_linear, r_angular) (u_t - v_t)
  + (u_t - u_{t-1})' diag(r_change_linear, r_change_angular) (u_t - u_{t-1}),
with diag(qf_xy, qf_xy, qf_yaw) on the last state (the ancillary problem's terminal condition
x_T = z_T, softened); u_{-1} is the last command sent (the measured velocity after a reset).
The change term is what keeps the feedback from answering each step's noise with a new command
(seed 000's "jerky"): the command is a filtered one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .. import _native
from ..config import positive, require
from ..geometry import wrap_angle
from ..robot import RobotSpec
from .mppi import MppiController, MppiPlan, MppiSettings
from .tracking import TrackingSettings


@dataclass(frozen=True)
class TubeMppiSettings:
    # the tube: beyond it the nominal state restarts from the measured one
    tube_radius_m: float = 0.1           # m, |x - z| in the plane: less than the clearance a
                                         # corridor leaves (the burger: ~0.14 m in 0.5 m)
    tube_yaw_rad: float = 0.8            # rad, |yaw - z_yaw|
    # iLQR's tracking cost (per model step); firm enough to hold seed 000's noisy unicycle in
    # the tube, soft enough not to chase every disturbance (bench-control's sweep: a 4x stiffer
    # q and 5x softer r triple the command jerk; bench-control's racetrack uses them: they
    # track tighter)
    q_xy_per_m2: float = 5.0             # 1/m^2
    q_yaw_per_rad2: float = 1.0          # 1/rad^2
    r_linear_s2_per_m2: float = 5.0      # s^2/m^2, on u - v: (m/s)^-2
    r_angular_s2_per_rad2: float = 0.5   # s^2/rad^2, on w - w_nominal: (rad/s)^-2
    qf_xy_per_m2: float = 50.0           # 1/m^2, terminal: the ancillary problem's x_T = z_T,
    qf_yaw_per_rad2: float = 10.0        # 1/rad^2, terminal    softened
    r_change_linear_s2_per_m2: float = 20.0    # s^2/m^2, on u_t - u_{t-1} (per model step)
    r_change_angular_s2_per_rad2: float = 2.0  # s^2/rad^2, on w_t - w_{t-1}
    ilqr_max_iterations: int = 5         # iterations per control step (warm: a few suffice)
    mppi: MppiSettings = field(default_factory=MppiSettings)   # the nominal's MPPI (config/mppi.yaml)

    def validate(self, src: str) -> None:
        positive(src, self, "tube_radius_m", "tube_yaw_rad", "r_linear_s2_per_m2",
                 "r_angular_s2_per_rad2", "ilqr_max_iterations")
        for key in ("q_xy_per_m2", "q_yaw_per_rad2", "qf_xy_per_m2", "qf_yaw_per_rad2",
                    "r_change_linear_s2_per_m2", "r_change_angular_s2_per_rad2"):
            v = getattr(self, key)
            require(math.isfinite(v) and v >= 0, src, key, f"must be >= 0, got {v!r}")
        require(self.tube_yaw_rad <= math.pi, src, "tube_yaw_rad", "must be <= pi")


class TubeMppiController(MppiController):
    """Tube MPPI behind the Controller contract (module docstring). The MPPI controller's
    checks and statuses apply to the ancillary's trajectory; ``optimize`` is one tube step
    from ``state`` as the measured state. ``trajectory`` is the ancillary's predicted
    trajectory, ``nominal_trajectory`` MPPI's; ``resets`` counts nominal resets (step 2)."""

    def __init__(self, settings: TubeMppiSettings, robot: RobotSpec,
                 tracking: Optional[TrackingSettings] = None, seed: Optional[int] = None):
        settings.validate("TubeMppiSettings")
        self.tube = settings
        self.resets = 0
        super().__init__(settings.mppi, robot, tracking, seed)


    def reset(self) -> None:
        super().reset()
        self._forget_nominal()

    def _forget_nominal(self) -> None:
        self._z: Optional[np.ndarray] = None       # the nominal state (x, y, yaw)
        self._z_velocity = (0.0, 0.0)              # its speeds (the nominal's last control)
        self._command: Optional[np.ndarray] = None  # the last command sent (v, w); None
                                                    # after a reset: the measured velocity
        self.nominal_trajectory = np.zeros((0, 3))

    def compute(self, inp):
        out = super().compute(inp)
        self._command = np.array([out.linear_mps, out.angular_radps])   # what was sent
        return out

    # ------------------------------------------------------------------ the tube step
    def _iterate(self, pose, velocity, goal_yaw, occupancy, resolution, origin,
                 period_s) -> MppiPlan:
        cfg, tube = self.settings, self.tube
        x = np.asarray(pose, float)
        # 2. tube: restart the nominal where the real state has left it
        if self._z is None or self._outside_tube(x):
            if self._z is not None:
                self.resets += 1
            self._z, self._z_velocity = x.copy(), tuple(velocity)
        # 3. nominal: MPPI from z
        nominal = super()._iterate(tuple(self._z), self._z_velocity, goal_yaw, occupancy,
                                   resolution, origin, period_s)
        # 4. ancillary: iLQR from x along (z_t, v_t)
        r = self.robot
        track = _native.ilqr_track(
            x, nominal.states, nominal.controls, dt=cfg.model_dt_s,
            q=(tube.q_xy_per_m2, tube.q_xy_per_m2, tube.q_yaw_per_rad2),
            r=(tube.r_linear_s2_per_m2, tube.r_angular_s2_per_rad2),
            qf=(tube.qf_xy_per_m2, tube.qf_xy_per_m2, tube.qf_yaw_per_rad2),
            r_change=(tube.r_change_linear_s2_per_m2, tube.r_change_angular_s2_per_rad2),
            u_prev=self._command if self._command is not None else np.asarray(velocity, float),
            u_min=(cfg.min_linear_mps, -r.max_angular_radps),
            u_max=(r.max_linear_mps, r.max_angular_radps),
            max_iterations=tube.ilqr_max_iterations)
        controls = track.controls
        first = self._accelerate(controls[0], velocity, period_s)
        if not np.array_equal(first, controls[0]):
            controls = controls.copy()
            controls[0] = first
        states = _rollout(x, controls, cfg.model_dt_s) if controls is not track.controls \
            else track.states
        # 6. advance the nominal by one control period along its own trajectory
        k = min(max(1, int(round(period_s / cfg.model_dt_s))), len(nominal.controls))
        self._z = nominal.states[k].copy()
        self._z_velocity = (float(nominal.controls[k - 1, 0]), float(nominal.controls[k - 1, 1]))
        self.nominal_trajectory = nominal.states
        self.trajectory = states
        self._start = tuple(self.nominal_trajectory[0])     # the rollouts start at z
        return MppiPlan(controls, states, nominal.min_cost, nominal.colliding,
                        nominal.all_collide, nominal.collides)

    def _outside_tube(self, x: np.ndarray) -> bool:
        z = self._z
        return (math.hypot(x[0] - z[0], x[1] - z[1]) > self.tube.tube_radius_m
                or abs(wrap_angle(x[2] - z[2])) > self.tube.tube_yaw_rad)

    def _accelerate(self, u: np.ndarray, velocity, period_s: float) -> np.ndarray:
        """``u`` within one period's acceleration of the measured velocity (and its limits)."""
        r, cfg = self.robot, self.settings
        v0 = min(max(velocity[0], cfg.min_linear_mps), r.max_linear_mps)
        w0 = min(max(velocity[1], -r.max_angular_radps), r.max_angular_radps)
        dv, dw = r.max_linear_accel_mps2 * period_s, r.max_angular_accel_radps2 * period_s
        return np.array([min(max(u[0], v0 - dv), v0 + dv), min(max(u[1], w0 - dw), w0 + dw)])

    def _stop(self, status: str, detail: str, target=None):
        out = super()._stop(status, detail, target)
        self._forget_nominal()                     # the robot stops: the nominal restarts at it
        return out


def _rollout(x0: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
    """Seed 000's discrete unicycle: x + dt (v cos yaw, v sin yaw, w), from x0."""
    out = np.empty((len(controls) + 1, 3))
    out[0] = x0
    for t, (v, w) in enumerate(controls):
        x, y, yaw = out[t]
        out[t + 1] = (x + dt * v * math.cos(yaw), y + dt * v * math.sin(yaw), yaw + dt * w)
    return out
