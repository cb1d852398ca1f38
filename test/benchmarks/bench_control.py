#!/usr/bin/env python3
"""Seed 000's control experiments, reproduced outside ROS (`make bench-control`), and the
controllers' cycle times, in one run -> output/bench/control.json, figures in output/bench/control/.

(a) The noisy unicycle (seed 000, section F.8, Fig. 5): from (0, 0) heading +x to (3, 3),
    50 control steps, 30 runs each for MPPI and Tube MPPI. Each step the command u gets
    control noise and the new state gets state noise:
      x+ = f(x, u + e_u) + e_x,  e_u ~ N(0, diag(0.5, 4)),  e_x ~ U[-0.06, 0.06]^2 x U[-0.3, 0.3].
    N(0, 0.5) is read as mean and VARIANCE (std 0.707 m/s on v, 2 rad/s on w): the paper writes
    the normal distribution as N(mean, .) next to uniform ranges, in the textbook notation
    N(mu, sigma^2), and a std of 4 rad/s on w would be more than the whole turn rate of its
    unicycle; the other reading (std 0.5 and 4) is run too (``*_std_reading``).
    dt = 0.1 s: the paper gives none; 50 steps of it (5 s) for the 4.24 m trip need a mean
    0.85 m/s, so its idealised unicycle drives ~1-2 m/s. Our unicycle: v in [-1, 2] m/s, w in
    [-3, 3] rad/s, no acceleration limits (the paper states no bounds), a 0.1 m disc.
    Both controllers steer all 50 steps, as seed 000's (which have no goal checker): ours
    latch the goal within ``xy_goal_tolerance_m`` and then stop, leaving the robot to the
    noise's random walk (~0.3 m over the 15 steps left after arriving), so the experiment sets
    it to 1 mm. Success: within ``SUCCESS_M`` of the goal after the 50th step. Jerk: the mean over the
    run of |v_{k+1} - 2 v_k + v_{k-1}| / dt^2 of the commanded v (m/s^3; ``*_angular_jerk``
    the same of w, rad/s^3). Path length: the true positions' polyline.
(b) The racetrack (F.9, Fig. 6): a circular lane, walls at radii ``TRACK_INNER_M`` and
    ``TRACK_OUTER_M`` (the paper's figure shows a ring about a lane wide; radii ours) on a
    0.05 m occupancy grid; the path is the centre line ahead (counter-clockwise), noise
    N(0, 0.5) on v, N(0, 2) on w (variance, as in (a)), U[-0.04, 0.04] on x, y, U[-0.2, 0.2] on
    yaw; ``TRACK_STEPS`` steps per run, ``TRACK_RUNS`` runs. A run ends at its first
    collision (the body's exact clearance <= 0): laps (polar angle travelled / 2 pi) and
    collisions per controller.
(c) Timings, 2000 samples x 56 steps of 0.05 s, the waffle_pi, one core: MPPI and its numpy
    twin (test/benchmarks/mppi_numpy.py's ``time_cycles``), one full Tube MPPI step (MPPI on
    the nominal + iLQR + the checks) on the same scene; dwa_ms_400, a full DWA step (400 arcs
    of 2 s and the checks) on it too.
The experiments use fewer samples than (c) (``EXPERIMENT_MPPI``), stated in the JSON.
"""
import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import TOP, write  # noqa: E402
from mppi_numpy import time_cycles, walled_map  # noqa: E402

from turtlebot_recon import _native  # noqa: E402
from turtlebot_recon.control import ControlInput  # noqa: E402
from turtlebot_recon.control.dwa import DwaController, DwaSettings  # noqa: E402
from turtlebot_recon.control.footprint import BodyCheck  # noqa: E402
from turtlebot_recon.control.mppi import MppiController, MppiSettings  # noqa: E402
from turtlebot_recon.control.tracking import TrackingSettings  # noqa: E402
from turtlebot_recon.control.tube_mppi import TubeMppiController, TubeMppiSettings  # noqa: E402
from turtlebot_recon.robot import RobotSpec, load_robot  # noqa: E402

FIGURES = TOP / "output" / "bench" / "control"
DT = 0.1                        # s, one control step = one model step
RES = 0.05                      # m per cell
# seed 000's idealised unicycle (bounds ours, see the module docstring)
UNICYCLE = RobotSpec(name="unicycle", wheel_radius_m=0.033, wheel_separation_m=0.16,
                     max_linear_mps=2.0, max_angular_radps=3.0, max_linear_accel_mps2=1e3,
                     max_angular_accel_radps2=1e3, radius_m=0.1)
EXPERIMENT_MPPI = MppiSettings(batch_size=1000, time_steps=30, model_dt_s=DT, control_rate_hz=1 / DT,
                               min_linear_mps=-1.0, noise_std_v_mps=0.5, noise_std_w_radps=1.0,
                               goal_region_m=3.0)
EXPERIMENT_TRACKING = TrackingSettings(rotate_threshold_rad=math.pi, xy_goal_tolerance_m=1e-3)
# (seed 000's controllers never turn on the spot first, rotate_threshold_rad pi switches it off;
# nor stop at the goal, xy_goal_tolerance_m 1 mm: see the module docstring)
# The tube wider than a step's noise (~0.1 m, 0.35 rad); iLQR stiffer than the robot's defaults
# (config/tube_mppi.yaml): on the racetrack the defaults' softer tracking crashes 9 runs of 10
# (0.7 laps), these 5 (2.5 laps), at about 3x the command jerk of the defaults.
EXPERIMENT_TUBE = TubeMppiSettings(tube_radius_m=0.5, tube_yaw_rad=1.5, q_xy_per_m2=20.0,
                                   r_linear_s2_per_m2=1.0, r_angular_s2_per_rad2=0.05,
                                   qf_xy_per_m2=200.0, qf_yaw_per_rad2=10.0,
                                   r_change_linear_s2_per_m2=0.0, r_change_angular_s2_per_rad2=0.0)
# "tube_mppi_smooth": the same with a cost on the change of the command (without it the
# feedback answers each step's noise) and a softer heading (the noise turns the robot by up to
# 0.3 rad a step): a quarter of the jerk on (a), but slower to turn on the racetrack
# (docs/benchmarks.md has the sweep).
EXPERIMENT_TUBE_SMOOTH = replace(EXPERIMENT_TUBE, q_yaw_per_rad2=0.2, r_change_linear_s2_per_m2=10.0,
                                 r_change_angular_s2_per_rad2=2.0)
# (a)
START, GOAL = (0.0, 0.0, 0.0), (3.0, 3.0)
STEPS, RUNS, SUCCESS_M = 50, 30, 0.3
WAYPOINT_NOISE = dict(control_std=(math.sqrt(0.5), math.sqrt(4.0)), state_half=(0.06, 0.06, 0.3))
WAYPOINT_NOISE_STD_READING = dict(control_std=(0.5, 4.0), state_half=(0.06, 0.06, 0.3))
# (b)
TRACK_INNER_M, TRACK_OUTER_M = 2.0, 3.0
TRACK_STEPS, TRACK_RUNS, TRACK_AHEAD_M = 300, 10, 10.0
TRACK_NOISE = dict(control_std=(math.sqrt(0.5), math.sqrt(2.0)), state_half=(0.04, 0.04, 0.2))
CONTROLLERS = ("mppi", "tube_mppi", "tube_mppi_smooth")


def make_controller(kind: str):
    """The experiments' controllers: seed 000's unicycle, the same MPPI settings for both."""
    if kind == "mppi":
        return MppiController(EXPERIMENT_MPPI, UNICYCLE, EXPERIMENT_TRACKING)
    tube = EXPERIMENT_TUBE_SMOOTH if kind == "tube_mppi_smooth" else EXPERIMENT_TUBE
    return TubeMppiController(replace(tube, mppi=EXPERIMENT_MPPI), UNICYCLE, EXPERIMENT_TRACKING)


def noisy_step(x: np.ndarray, u: np.ndarray, rng, control_std, state_half) -> np.ndarray:
    """x+ = f(x, u + e_u) + e_x: seed 000's unicycle with its control and state noise."""
    v, w = u + rng.normal(0.0, control_std)
    x = x + DT * np.array([v * math.cos(x[2]), v * math.sin(x[2]), w])
    return x + rng.uniform(-np.asarray(state_half), np.asarray(state_half))


def drive(controller, x0, path_of, steps, noise, rng, occupancy, origin, crashed=None) -> dict:
    """Closed loop: the controller sees the true state (and its last command as the measured
    velocity) each step; ``path_of(x)`` the global path from there. Stops at ``crashed(x)``."""
    controller.reset()
    costmap = np.zeros(occupancy.shape, np.uint8)
    x, u = np.asarray(x0, float), np.zeros(2)
    states, commands = [x.copy()], []
    for k in range(steps):
        inp = ControlInput(k * DT, tuple(x), tuple(u), path_of(x), None, occupancy, costmap, RES,
                           origin)
        out = controller.compute(inp)
        u = np.array([out.linear_mps, out.angular_radps])
        commands.append(u)
        x = noisy_step(x, u, rng, **noise)
        states.append(x.copy())
        if crashed is not None and crashed(x):
            break
    return dict(states=np.array(states), commands=np.array(commands))


def jerk(commands: np.ndarray, dt: float = DT) -> np.ndarray:
    """Mean |second difference| / dt^2 of each command column (v: m/s^3, w: rad/s^3), the
    commands dt apart."""
    if len(commands) < 3:
        return np.zeros(2)
    return np.abs(np.diff(commands, n=2, axis=0)).mean(axis=0) / dt ** 2


def path_length(states: np.ndarray) -> float:
    return float(np.hypot(*np.diff(states[:, :2], axis=0).T).sum())


# ---------------------------------------------------------------------- (a) the noisy unicycle
def empty_map():
    """16 x 16 m of free cells about the trip (MPPI wants the map twice its rollouts' reach)."""
    n = int(round(16.0 / RES))
    return np.zeros((n, n), np.int8), (-6.5, -6.5)


def noisy_unicycle(kind: str, runs: int, noise: dict) -> dict:
    occupancy, origin = empty_map()
    controller = make_controller(kind)
    goal = np.array(GOAL)
    out = dict(paths=[], final=[], length=[], jerk=[], reached=[])
    for run in range(runs):
        r = drive(controller, START, lambda x: np.array([x[:2], goal]), STEPS, noise,
                  np.random.default_rng(run), occupancy, origin)
        d = np.hypot(*(r["states"][:, :2] - goal).T)
        out["paths"].append(r["states"])
        out["final"].append(float(d[-1]))
        out["reached"].append(bool(d.min() <= SUCCESS_M))
        out["length"].append(path_length(r["states"]))
        out["jerk"].append(jerk(r["commands"]))
    out["resets"] = getattr(controller, "resets", 0)
    return out


def figure_waypoint(results: dict, path: Path) -> None:
    """Seed 000's Fig. 5: the 30 paths of each controller, start (orange star), goal (blue x)."""
    fig, axes = plt.subplots(1, len(CONTROLLERS), figsize=(5 * len(CONTROLLERS), 5), sharex=True,
                             sharey=True)
    for ax, kind in zip(axes, CONTROLLERS):
        for p in results[kind]["paths"]:
            ax.plot(p[:, 0], p[:, 1], lw=0.8, alpha=0.7)
        ax.plot(*START[:2], "*", color="orange", ms=16, label="start")
        ax.plot(*GOAL, "x", color="blue", ms=12, mew=3, label="goal")
        ax.add_patch(plt.Circle(GOAL, SUCCESS_M, fill=False, ls="--", color="blue"))
        rate = np.mean(np.array(results[kind]["final"]) <= SUCCESS_M)
        ax.set_title(f"{kind.replace('_', ' ').upper()}: {len(results[kind]['paths'])} runs, "
                     f"{100 * rate:.0f} % end within {SUCCESS_M} m")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("y (m)")
    axes[0].legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------- (b) the racetrack
def racetrack_map():
    """A ring lane between TRACK_INNER_M and TRACK_OUTER_M about (0, 0); 14 x 14 m."""
    n = int(round(14.0 / RES))
    origin = (-7.0, -7.0)
    c = origin[0] + (np.arange(n) + 0.5) * RES
    r = np.hypot(*np.meshgrid(c, c))
    occupancy = np.where((r < TRACK_INNER_M) | (r > TRACK_OUTER_M), 100, 0).astype(np.int8)
    return occupancy, origin


def centre_line_ahead(x: np.ndarray) -> np.ndarray:
    """The robot's position, then the lane's centre line from its polar angle on, TRACK_AHEAD_M
    counter-clockwise (the goal stays beyond the rollouts' reach)."""
    radius = 0.5 * (TRACK_INNER_M + TRACK_OUTER_M)
    phi = math.atan2(x[1], x[0]) + np.arange(0.0, TRACK_AHEAD_M, 0.25) / radius
    return np.vstack([x[:2], np.column_stack([radius * np.cos(phi), radius * np.sin(phi)])])


def racetrack(kind: str, runs: int, steps: int) -> dict:
    occupancy, origin = racetrack_map()
    controller = make_controller(kind)
    body = BodyCheck(UNICYCLE, 0.0)
    grid = ControlInput(0.0, (0, 0, 0), (0, 0), np.zeros((0, 2)), None, occupancy,
                        np.zeros(occupancy.shape, np.uint8), RES, origin)
    start = (0.5 * (TRACK_INNER_M + TRACK_OUTER_M), 0.0, math.pi / 2)

    def crashed(x):
        return not np.isfinite(x).all() or body.clearance(grid, [x], 0.1)[0] <= 0.0

    out = dict(paths=[], laps=[], crash_step=[], jerk=[])
    for run in range(runs):
        r = drive(controller, start, centre_line_ahead, steps, TRACK_NOISE,
                  np.random.default_rng(100 + run), occupancy, origin, crashed)
        s = r["states"]
        phi = np.unwrap(np.arctan2(s[:, 1], s[:, 0]))
        out["paths"].append(s)
        out["laps"].append(float((phi[-1] - phi[0]) / (2 * math.pi)))
        out["crash_step"].append(len(s) - 1 if crashed(s[-1]) else None)
        out["jerk"].append(jerk(r["commands"]))
    return out


def figure_racetrack(results: dict, path: Path) -> None:
    """Seed 000's Fig. 6: one run of each controller around the track (the first run)."""
    occupancy, origin = racetrack_map()
    extent = (origin[0], origin[0] + occupancy.shape[1] * RES, origin[1],
              origin[1] + occupancy.shape[0] * RES)
    fig, axes = plt.subplots(len(CONTROLLERS), 1, figsize=(6, 5.5 * len(CONTROLLERS)))
    for ax, kind in zip(axes, CONTROLLERS):
        ax.imshow(occupancy > 50, origin="lower", extent=extent, cmap="Greys", alpha=0.6)
        s = results[kind]["paths"][0]
        ax.plot(s[:, 0], s[:, 1], lw=1.0, color="tab:red" if kind == "mppi" else "tab:blue")
        ax.plot(*s[0, :2], "*", color="orange", ms=14)
        crash = results[kind]["crash_step"][0]
        if crash is not None:
            ax.plot(*s[-1, :2], "kx", ms=12, mew=3, label=f"collision at step {crash}")
            ax.legend(loc="upper right")
        ax.set_title(f"{kind.replace('_', ' ').upper()}: {results[kind]['laps'][0]:.2f} laps "
                     f"in {len(s) - 1} of {TRACK_STEPS} steps")
        ax.set_xlim(-3.5, 3.5)
        ax.set_ylim(-3.5, 3.5)
        ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------- (c) timings
def tube_cycle_ms(cycles: int, batch_size: int = 2000, time_steps: int = 56) -> float:
    """Median ms of one full Tube MPPI step (compute(): checks, MPPI from the nominal, iLQR, the
    exact body check) on time_cycles' scene: the waffle_pi 1 m before a door, at speed."""
    robot = load_robot("turtlebot3_waffle_pi")
    s = MppiSettings(batch_size=batch_size, time_steps=time_steps)
    controller = TubeMppiController(replace(TubeMppiSettings(), mppi=s), robot)
    occupancy = walled_map()
    costmap = np.zeros(occupancy.shape, np.uint8)
    path = np.array([[3.5, 5.0], [4.0, 5.0], [6.0, 5.0], [6.0, 8.0]])
    ms = []
    for k in range(cycles + 1):
        pose = (3.5 + 0.01 * (k % 3), 5.0, 0.0)              # a little off the nominal
        inp = ControlInput(k * s.model_dt_s, pose, (0.2, 0.0), path, None, occupancy, costmap,
                           RES, (0.0, 0.0))
        t0 = time.perf_counter()
        controller.compute(inp)
        if k:                                                  # the first builds the field
            ms.append(1e3 * (time.perf_counter() - t0))
    return float(np.median(ms))


def dwa_cycle_ms(cycles: int) -> float:
    """Median ms of one full DWA step (compute(): the 20 x 20 = 400 arcs of 2 s, the checks,
    the exact body check) on tube_cycle_ms' scene."""
    robot = load_robot("turtlebot3_waffle_pi")
    settings = DwaSettings()
    assert settings.linear_samples * settings.angular_samples == 400
    controller = DwaController(settings, robot)
    occupancy = walled_map()
    costmap = np.zeros(occupancy.shape, np.uint8)
    path = np.array([[3.5, 5.0], [4.0, 5.0], [6.0, 5.0], [6.0, 8.0]])
    ms = []
    for k in range(cycles + 1):
        inp = ControlInput(k * 0.1, (3.5 + 0.01 * (k % 3), 5.0, 0.0), (0.2, 0.0), path, None, occupancy,
                           costmap, RES, (0.0, 0.0))
        t0 = time.perf_counter()
        controller.compute(inp)
        if k:
            ms.append(1e3 * (time.perf_counter() - t0))
    return float(np.median(ms))


# ---------------------------------------------------------------------- main
def summary(prefix: str, r: dict) -> dict:
    final = np.array(r["final"])
    j = np.array(r["jerk"])
    return {f"{prefix}_success_rate": float(np.mean(final <= SUCCESS_M)),
            f"{prefix}_reached_rate": float(np.mean(r["reached"])),
            f"{prefix}_final_distance_m": float(final.mean()),
            f"{prefix}_final_distance_median_m": float(np.median(final)),
            f"{prefix}_path_length_m": float(np.mean(r["length"])),
            f"{prefix}_jerk": float(j[:, 0].mean()),
            f"{prefix}_angular_jerk": float(j[:, 1].mean())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=RUNS, help="runs per controller in (a)")
    ap.add_argument("--track-runs", type=int, default=TRACK_RUNS, help="runs per controller in (b)")
    ap.add_argument("--cycles", type=int, default=50, help="timed cycles in (c)")
    args = ap.parse_args()
    FIGURES.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    fig = {"experiment_dt_s": DT, "experiment_batch_size": EXPERIMENT_MPPI.batch_size,
           "experiment_time_steps": EXPERIMENT_MPPI.time_steps,
           "unicycle_max_linear_mps": UNICYCLE.max_linear_mps,
           "unicycle_min_linear_mps": EXPERIMENT_MPPI.min_linear_mps,
           "unicycle_max_angular_radps": UNICYCLE.max_angular_radps,
           "success_tolerance_m": SUCCESS_M, "waypoint_runs": args.runs,
           "tube_radius_m": EXPERIMENT_TUBE.tube_radius_m,
           "tube_yaw_rad": EXPERIMENT_TUBE.tube_yaw_rad,
           "tube_q_xy_per_m2": EXPERIMENT_TUBE.q_xy_per_m2,
           "tube_r_linear_s2_per_m2": EXPERIMENT_TUBE.r_linear_s2_per_m2,
           "tube_smooth_q_yaw_per_rad2": EXPERIMENT_TUBE_SMOOTH.q_yaw_per_rad2,
           "tube_smooth_r_change_linear_s2_per_m2": EXPERIMENT_TUBE_SMOOTH.r_change_linear_s2_per_m2,
           "tube_smooth_r_change_angular_s2_per_rad2": EXPERIMENT_TUBE_SMOOTH.r_change_angular_s2_per_rad2,
           "experiment_xy_goal_tolerance_m": EXPERIMENT_TRACKING.xy_goal_tolerance_m}

    # (a)
    waypoint = {k: noisy_unicycle(k, args.runs, WAYPOINT_NOISE) for k in CONTROLLERS}
    for k in CONTROLLERS:
        fig.update(summary(k, waypoint[k]))
    for k in CONTROLLERS[1:]:
        fig[f"{k}_nominal_resets"] = waypoint[k]["resets"]
    figure_waypoint(waypoint, FIGURES / "noisy_unicycle.png")
    for k in CONTROLLERS:
        r = noisy_unicycle(k, args.runs, WAYPOINT_NOISE_STD_READING)
        fig[f"{k}_success_rate_std_reading"] = float(np.mean(np.array(r["final"]) <= SUCCESS_M))
        fig[f"{k}_final_distance_std_reading_m"] = float(np.mean(r["final"]))

    # (b)
    track = {k: racetrack(k, args.track_runs, TRACK_STEPS) for k in CONTROLLERS}
    fig.update({"racetrack_inner_radius_m": TRACK_INNER_M, "racetrack_outer_radius_m": TRACK_OUTER_M,
                "racetrack_steps": TRACK_STEPS, "racetrack_runs": args.track_runs})
    for k in CONTROLLERS:
        crashes = [c for c in track[k]["crash_step"] if c is not None]
        fig[f"{k}_racetrack_laps"] = float(np.mean(track[k]["laps"]))
        fig[f"{k}_racetrack_collisions"] = len(crashes)
        fig[f"{k}_racetrack_first_collision_step"] = (float(np.mean(crashes)) if crashes
                                                      else None)
        fig[f"{k}_racetrack_jerk"] = float(np.array(track[k]["jerk"])[:, 0].mean())
    figure_racetrack(track, FIGURES / "racetrack.png")
    fig["experiments_s"] = time.perf_counter() - t_start

    # (c)
    fig.update(time_cycles(cycles=args.cycles))
    fig["tube_mppi_ms"] = tube_cycle_ms(args.cycles)
    fig["dwa_ms_400"] = dwa_cycle_ms(args.cycles)
    write("control", {k: v for k, v in fig.items() if v is not None})


if __name__ == "__main__":
    main()
