"""MPPI in numpy: the reference of the C++ optimizer (include/turtlebot_recon/mppi/) and the
denominator of ``mppi_ratio_vs_numpy``.

The same algorithm, vectorised over the batch (no Python loop over rollouts; loops over the T
time steps only where the maths is sequential in time): the motion model (velocity and
acceleration limits, Euler unicycle); Gaussian noise drawn every ``noise_knot_steps`` steps and
interpolated linearly (numpy's generator, so not the same numbers as C++); rollout 0 the warm
start, rollout 1 a stop; the critics goal_distance, goal_heading, path_follow, path_align
(every 4th pose; off where the body does not fit on the path), obstacle (the body against the
distance field: the disc cover's bound, and where that is below the margin the box's outline
points, bilinear lookups, as obstacle.hpp and body_field.hpp),
prefer_forward; the softmax with temperature lambda; the weighted update of the sampled
sequences, within the velocity limits; Savitzky-Golay smoothing; the warm start's shift.

``time_cycles()`` measures one cycle of each at 2000 x 56 on a 10 x 10 m map with walls.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from scipy import ndimage

SG_COEFF = np.array([-21, 14, 39, 54, 59, 54, 39, 14, -21], float) / 231.0


# ---------------------------------------------------------------------- motion model
def constrain(v_req: np.ndarray, w_req: np.ndarray, v0: float, w0: float, dt: float, lim: dict):
    """The requested speeds [K x T] made feasible, step by step from (v0, w0)."""
    v, w = np.empty_like(v_req), np.empty_like(w_req)
    dv, dw = lim["max_linear_accel_mps2"] * dt, lim["max_angular_accel_radps2"] * dt
    vp, wp = np.full(v_req.shape[0], v0), np.full(w_req.shape[0], w0)
    for t in range(v_req.shape[1]):
        vt = np.clip(v_req[:, t], vp - dv, vp + dv)
        wt = np.clip(w_req[:, t], wp - dw, wp + dw)
        if lim.get("clamp_velocity", True):
            vt = np.clip(vt, lim["min_linear_mps"], lim["max_linear_mps"])
            wt = np.clip(wt, -lim["max_angular_radps"], lim["max_angular_radps"])
        v[:, t], w[:, t] = vt, wt
        vp, wp = vt, wt
    return v, w


def integrate(v: np.ndarray, w: np.ndarray, pose, dt: float):
    """Poses after each step [K x T] each of x, y, yaw (seed 000's Euler unicycle)."""
    yaw = pose[2] + dt * np.cumsum(w, axis=1)
    heading = np.concatenate([np.full((v.shape[0], 1), pose[2]), yaw[:, :-1]], axis=1)
    x = pose[0] + dt * np.cumsum(v * np.cos(heading), axis=1)
    y = pose[1] + dt * np.cumsum(v * np.sin(heading), axis=1)
    return x, y, yaw


def knot_noise(rng, K: int, T: int, std: float, knot_steps: int) -> np.ndarray:
    """noise_generator.hpp: N(0, std^2) every knot_steps steps, linear between [K x T]."""
    knots = std * rng.standard_normal((K, (T - 1) // knot_steps + 2))
    t = np.arange(T)
    j, f = t // knot_steps, (t % knot_steps) / knot_steps
    return (1 - f) * knots[:, j] + f * knots[:, j + 1]


# ---------------------------------------------------------------------- the body and the map
class Field:
    """body_field.hpp's DistanceField: distance to the nearest obstacle cell's centre less half a
    cell, bilinear between cell centres, clamped to the grid's edge cells."""

    def __init__(self, occupancy: np.ndarray, resolution: float, origin, threshold: int = 65):
        obstacle = occupancy >= threshold
        self.res, self.ox, self.oy = resolution, float(origin[0]), float(origin[1])
        self.rows, self.cols = occupancy.shape
        if obstacle.any():
            self.d = ndimage.distance_transform_edt(~obstacle) * resolution - 0.5 * resolution
        else:
            self.d = np.full(occupancy.shape, 1e3)

    def contains(self, x, y):
        c, r = (x - self.ox) / self.res, (y - self.oy) / self.res
        return (c >= 0) & (r >= 0) & (c < self.cols) & (r < self.rows)

    def at(self, x, y):
        fc = np.clip((x - self.ox) / self.res - 0.5, 0, self.cols - 1)
        fr = np.clip((y - self.oy) / self.res - 0.5, 0, self.rows - 1)
        c0 = np.minimum(fc.astype(int), self.cols - 1)
        r0 = np.minimum(fr.astype(int), self.rows - 1)
        c1, r1 = np.minimum(c0 + 1, self.cols - 1), np.minimum(r0 + 1, self.rows - 1)
        tc, tr = fc - c0, fr - r0
        top = (1 - tc) * self.d[r0, c0] + tc * self.d[r0, c1]
        bottom = (1 - tc) * self.d[r1, c0] + tc * self.d[r1, c1]
        return (1 - tr) * top + tr * bottom


def outline(robot, spacing_m: float = 0.05):
    """(outline points (P, 2), centre (2,), inscribed m, circumscribed m), body_field.hpp's."""
    if robot.is_round:
        return None, None, 0.0, robot.radius_m
    hl, hw = 0.5 * robot.footprint_length_m, 0.5 * robot.footprint_width_m
    ox = robot.footprint_offset_x_m
    corners = np.array([[ox - hl, -hw], [ox + hl, -hw], [ox + hl, hw], [ox - hl, hw]])
    pts = []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        n = max(1, int(math.ceil(np.hypot(*(b - a)) / spacing_m)))
        pts += [a + (b - a) * i / n for i in range(n)]
    radius = max(robot.radius_m, math.hypot(abs(ox) + hl, hw))
    return np.array(pts), np.array([ox, 0.0]), min(hl, hw), radius


def disc_cover(robot, bulge_m: float = 0.01):
    """obstacle.hpp's cover of the body: (centres (n, 2) robot frame, radius m)."""
    if robot.is_round:
        return np.zeros((1, 2)), robot.radius_m
    length, hw = robot.footprint_length_m, 0.5 * robot.footprint_width_m
    half_step = math.sqrt((hw + bulge_m) ** 2 - hw ** 2)
    n = max(1, int(math.ceil(length / (2 * half_step))))
    x0 = robot.footprint_offset_x_m - 0.5 * length
    centres = np.column_stack([x0 + (np.arange(n) + 0.5) * length / n, np.zeros(n)])
    return centres, math.hypot(0.5 * length / n, hw)


def cover_clearance(field: Field, cover, x, y, yaw, max_m: float):
    """The disc cover's lower bound of the body's clearance, capped at max_m."""
    centres, radius = cover
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    px = x[..., None] + c * centres[:, 0] - s * centres[:, 1]
    py = y[..., None] + s * centres[:, 0] + c * centres[:, 1]
    return np.minimum(field.at(px, py).min(axis=-1) - radius, max_m)


def body_clearance(field: Field, body, x, y, yaw, max_m: float):
    """body_field.hpp's body_clearance on arrays of poses."""
    pts, centre, inscribed, radius = body
    d0 = field.at(x, y)
    if pts is None:
        return np.minimum(d0 - radius, max_m)
    out = np.full(np.shape(x), max_m, float)
    near = d0 - radius < max_m
    if near.any():
        xn, yn, c, s = x[near], y[near], np.cos(yaw[near]), np.sin(yaw[near])
        px = xn[:, None] + c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1]
        py = yn[:, None] + s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1]
        least = np.minimum(field.at(px, py).min(axis=1), max_m)
        inner = field.at(xn + c * centre[0], yn + s * centre[0]) - inscribed
        out[near] = np.where(inner < 0, np.minimum(least, inner), least)
    return out


# ---------------------------------------------------------------------- the optimizer
class NumpyMppi:
    """optimizer.hpp in numpy; ``s`` an MppiSettings, ``robot`` a RobotSpec."""

    def __init__(self, s, robot, field: Field, seed: int = 0):
        self.s, self.robot, self.field = s, robot, field
        self.body = outline(robot, s.outline_spacing_m)
        self.cover = disc_cover(robot)
        self.lim = dict(min_linear_mps=s.min_linear_mps, max_linear_mps=robot.max_linear_mps,
                        max_angular_radps=robot.max_angular_radps,
                        max_linear_accel_mps2=robot.max_linear_accel_mps2,
                        max_angular_accel_radps2=robot.max_angular_accel_radps2,
                        clamp_velocity=s.clamp_velocity)
        self.rng = np.random.default_rng(seed)
        self.u = np.zeros((s.time_steps, 2))
        self.history = np.zeros((4, 2))
        self.reach = max(robot.max_linear_mps, -s.min_linear_mps) * s.time_steps * s.model_dt_s

    def optimize(self, pose, velocity, path: np.ndarray, goal, goal_yaw=None, shift_steps=1):
        s, K, T, dt = self.s, self.s.batch_size, self.s.time_steps, self.s.model_dt_s
        # 1. shift
        n = min(max(shift_steps, 0), T - 1)
        if n:
            self.u = np.concatenate([self.u[n:], np.repeat(self.u[-1:], n, axis=0)])
        # 2. sample
        v_req = self.u[:, 0] + knot_noise(self.rng, K, T, s.noise_std_v_mps, s.noise_knot_steps)
        w_req = self.u[:, 1] + knot_noise(self.rng, K, T, s.noise_std_w_radps, s.noise_knot_steps)
        v_req[0], w_req[0], v_req[1], w_req[1] = self.u[:, 0], self.u[:, 1], 0.0, 0.0
        v, w = constrain(v_req, w_req, velocity[0], velocity[1], dt, self.lim)
        # 3. rollout
        x, y, yaw = integrate(v, w, pose, dt)
        # 4. critics
        cost = self._score(pose, goal, goal_yaw, path, x, y, yaw, v, w)
        # 5-6. softmax, update
        wts = np.exp(-(cost - cost.min()) / s.temperature)
        wts /= wts.sum()
        lim, w_max = self.lim, self.lim["max_angular_radps"]
        self.u = np.stack([np.clip(wts @ v_req, lim["min_linear_mps"], lim["max_linear_mps"]),
                           np.clip(wts @ w_req, -w_max, w_max)], axis=1)
        # 7. smoothing
        if s.smooth:
            padded = np.concatenate([self.history, self.u, np.repeat(self.u[-1:], 4, axis=0)])
            self.u = np.stack([np.convolve(padded[:, j], SG_COEFF[::-1], mode="valid")
                               for j in range(2)], axis=1)
        # 8. feasible again, its trajectory
        uv, uw = constrain(self.u[None, :, 0], self.u[None, :, 1], *velocity[:2], dt, self.lim)
        self.u = np.stack([uv[0], uw[0]], axis=1)
        self.history = np.concatenate([self.history[1:], self.u[:1]])
        tx, ty, tyaw = integrate(uv, uw, pose, dt)
        states = np.vstack([np.asarray(pose, float), np.column_stack([tx[0], ty[0], tyaw[0]])])
        return self.u.copy(), states, cost

    def _score(self, pose, goal, goal_yaw, path, x, y, yaw, v, w):
        s = self.s
        cost = np.zeros(x.shape[0])
        d_goal = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
        path_left = math.hypot(path[0, 0] - pose[0], path[0, 1] - pose[1]) + np.hypot(*np.diff(path, axis=0).T).sum()
        near_goal = max(d_goal, path_left) <= s.goal_region_m
        if near_goal:
            cost += s.goal_distance_weight * np.hypot(x - goal[0], y - goal[1]).mean(axis=1)
        if goal_yaw is not None and d_goal <= s.goal_heading_threshold_m:
            err = (yaw - goal_yaw + math.pi) % (2 * math.pi) - math.pi
            cost += s.goal_heading_weight * np.abs(err).mean(axis=1)
        if not near_goal:
            seg = np.hypot(*np.diff(path, axis=0).T)
            sl = np.concatenate([[0.0], np.cumsum(seg)])
            target = [np.interp(min(self.reach, sl[-1]), sl, path[:, j]) for j in range(2)]
            cost += s.path_follow_weight * np.hypot(x[:, -1] - target[0], y[:, -1] - target[1])
            if self._path_fits(path, sl):
                cols = np.arange((x.shape[1] - 1) % 4, x.shape[1], 4)
                px, py = x[:, cols], y[:, cols]
                d = np.sqrt(((px[..., None] - path[:, 0]) ** 2
                             + (py[..., None] - path[:, 1]) ** 2).min(axis=-1))
                cost += s.path_align_weight * d.mean(axis=1)
        cost += self._obstacle(pose, x, y, yaw)
        cost += s.prefer_forward_weight * np.maximum(-v, 0).mean(axis=1)
        return cost

    def _path_fits(self, path, sl):
        """The body, heading along the path, keeps the margin at its points within the reach."""
        step = np.diff(path, axis=0)
        keep = (sl[:-1] <= self.reach) & (np.abs(step).sum(axis=1) > 0)   # segments begun within it
        pts, heading = path[1:][keep], np.arctan2(step[keep, 1], step[keep, 0])
        c = body_clearance(self.field, self.body, pts[:, 0], pts[:, 1], heading,
                           self.s.collision_margin_m)
        return bool((c >= self.s.collision_margin_m).all())

    def _obstacle(self, pose, x, y, yaw):
        s = self.s
        band = max(s.obstacle_band_m, s.collision_margin_m)
        start = body_clearance(self.field, self.body, np.array([pose[0]]), np.array([pose[1]]),
                               np.array([pose[2]]), band)[0]
        below = min(s.collision_margin_m, start - 1e-3)
        c = np.full(x.shape, band)
        near = self.field.at(x, y) - self.body[3] < band   # beyond: clear (ClearMask's job)
        c[near] = cover_clearance(self.field, self.cover, x[near], y[near], yaw[near], band)
        low = c < s.collision_margin_m                     # the outline decides there
        c[low] = body_clearance(self.field, self.body, x[low], y[low], yaw[low], band)
        c[~self.field.contains(x, y)] = -1.0
        hit = c < below
        before = np.cumsum(hit, axis=1) == 0               # the poses before the first collision
        repulsion = np.where(before & (c < band), band - c, 0.0).sum(axis=1)
        return (s.obstacle_weight / (band * x.shape[1]) * repulsion
                + s.collision_cost * hit.any(axis=1))


# ---------------------------------------------------------------------- timing
def walled_map(res: float = 0.05):
    """10 x 10 m: outer walls, two interior walls with doors, a few boxes."""
    n = int(round(10.0 / res))
    occ = np.zeros((n, n), np.int8)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = 100
    occ[:, 98:102] = 100
    occ[90:110, 98:102] = 0                                 # a 1 m door at y = 4.5..5.5
    occ[140:144, :] = 100
    occ[140:144, 30:50] = 0
    for r, c in ((60, 40), (120, 150), (30, 160)):
        occ[r:r + 6, c:c + 6] = 100
    return occ


def time_cycles(cycles: int = 50, numpy_cycles: int = 10, robot_name: str = "turtlebot3_waffle_pi",
                batch_size: int = 2000, time_steps: int = 56, threads: int = 2) -> dict:
    """Median ms of one MPPI cycle, C++ on one core, C++ with ``threads`` threads in the
    obstacle and path_align critics, and numpy, batch_size x time_steps, the waffle_pi driving
    along a path through a door on ``walled_map()``; the map's distance field is built outside
    the timing (once per map, as the controller does). The call itself (path densifying, the
    binding's conversions) is inside it."""
    from turtlebot_recon.control.mppi import MppiController, MppiSettings
    from turtlebot_recon.robot import load_robot

    robot = load_robot(robot_name)
    s = MppiSettings(batch_size=batch_size, time_steps=time_steps)
    occ, res, origin = walled_map(), 0.05, (0.0, 0.0)
    path = np.array([[2.0, 5.0], [4.0, 5.0], [6.0, 5.0], [6.0, 8.0]])
    start, speed = (3.5, 5.0, 0.0), (0.2, 0.0)             # 1 m before the door, at speed

    def median_ms(ctrl, n):
        ctrl.optimize(start, speed, path, None, occ, res, origin)      # map and buffers, untimed
        ms = []
        for _ in range(n):
            t0 = time.perf_counter()
            ctrl.optimize(start, speed, path, None, occ, res, origin, period_s=s.model_dt_s)
            ms.append(1e3 * (time.perf_counter() - t0))
        return float(np.median(ms))

    cpp = MppiController(s, robot)
    cpp_ms = median_ms(cpp, cycles)
    threaded_ms = median_ms(MppiController(dataclasses.replace(s, threads=threads), robot), cycles)

    ref = NumpyMppi(s, robot, Field(occ, res, origin))
    dense = cpp._local_path()                                       # the same local path
    goal = tuple(path[-1])
    ms_np = []
    for _ in range(numpy_cycles):
        t0 = time.perf_counter()
        ref.optimize(start, speed, dense, goal)
        ms_np.append(1e3 * (time.perf_counter() - t0))
    np_ms = float(np.median(ms_np))
    key = f"{batch_size}x{time_steps}"
    return {f"mppi_ms_{key}": cpp_ms, f"mppi_ms_{key}_threads{threads}": threaded_ms,
            f"mppi_numpy_ms_{key}": np_ms, "mppi_ratio_vs_numpy": np_ms / cpp_ms}


if __name__ == "__main__":
    print(time_cycles())
