"""DESIGN §6 metrics. The robot's map frame is its start pose; only the evaluator knows the
transform to world coordinates (``map_to_world`` = the world's start pose)."""
from __future__ import annotations

import math

import numpy as np

from ..geometry import cells_to_points, inside, points_to_cells
from ..mapping.map_io import FREE_THRESH, OCCUPIED_THRESH
from ..sim.world import World


def map_cells_in_world(shape: tuple, resolution: float, origin_xy: tuple, map_to_world: tuple) -> tuple:
    """World (x, y) of every cell centre of a robot map, as two (rows, cols) arrays."""
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    m = cells_to_points(np.column_stack([rows.ravel(), cols.ravel()]), resolution, origin_xy)
    mx, my = m[:, 0].reshape(shape), m[:, 1].reshape(shape)
    x0, y0, yaw = map_to_world
    c, s = math.cos(yaw), math.sin(yaw)
    return x0 + c * mx - s * my, y0 + s * mx + c * my


def _sample(grid: np.ndarray, world: World, wx: np.ndarray, wy: np.ndarray, outside):
    """``grid`` (a world-grid array) at world points (m), ``outside`` for points off the world."""
    r, c = points_to_cells(np.column_stack([wx, wy]), world.resolution, world.origin)
    on_grid = inside(r, c, grid.shape)
    out = np.full(r.shape, outside, dtype=grid.dtype)
    out[on_grid] = grid[r[on_grid], c[on_grid]]
    return out


def map_precision(occupancy: np.ndarray, resolution: float, origin_xy: tuple, world: World,
                  map_to_world: tuple) -> dict:
    """Map precision (DESIGN §6).

    occupied: of the cells the robot marks occupied (>= 65), the fraction within one cell of a
    true obstacle: the nearest solid edge is at most 1.5 cells from the cell centre (one cell
    beyond the cell's own half width).
    free: of the cells it marks free (0..25), the fraction whose centre is truly free.
    """
    wx, wy = map_cells_in_world(occupancy.shape, resolution, origin_xy, map_to_world)
    occ = occupancy >= OCCUPIED_THRESH
    free = (occupancy >= 0) & (occupancy <= FREE_THRESH)
    clearance = _sample(world.clearance(), world, wx[occ], wy[occ], 0.0)
    truly_free = _sample(world.free, world, wx[free], wy[free], False)
    n_occ, n_free = int(occ.sum()), int(free.sum())
    return {
        "map_precision_occupied": float(np.mean(clearance <= 1.5 * resolution)) if n_occ else None,
        "map_precision_free": float(np.mean(truly_free)) if n_free else None,
        "cells_occupied": n_occ,
        "cells_free": n_free,
    }


def distance_until(path: np.ndarray, t_s):
    """Metres along a recorded path (rows of sim time s, x m, y m, in time order) up to sim
    time ``t_s``: the distance driven until a coverage milestone (report.json's
    distance_to_99_m). None when ``t_s`` is None (never reached)."""
    if t_s is None:
        return None
    p = np.asarray(path, dtype=float).reshape(-1, 3)
    p = p[p[:, 0] <= t_s]
    return float(np.hypot(*np.diff(p[:, 1:], axis=0).T).sum()) if len(p) > 1 else 0.0


STANDING_SPEED_MPS = 0.05   # slower than this (true ground speed) the robot stands (issue 30)
STOP_MIN_S = 0.5            # a standing spell shorter than this is no stop, a moving spell
                            # shorter than this between two standing ones no start (a twitch)


def standing(poses: np.ndarray, t0_s: float, t1_s: float) -> tuple:
    """(time_standing_s, stops) between sim times ``t0_s`` and ``t1_s`` of a ground-truth
    trajectory (rows of sim time s, x m, y m, ...; time order).

    Each interval between consecutive samples is standing when its mean speed (distance over
    time) is under ``STANDING_SPEED_MPS``: turning in place stands, as it does not advance the
    robot. time_standing_s sums the standing intervals' time within the window. A stop is a
    change from moving to standing: a standing spell of at least ``STOP_MIN_S`` after the robot
    has moved (standing at the window's start is no stop), moving spells shorter than
    ``STOP_MIN_S`` between two standing ones counted as standing (they do not end a stop)."""
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or len(p) < 2 or t1_s <= t0_s:
        return 0.0, 0
    a, b = p[:-1, 0], p[1:, 0]
    ok = b > a
    a, b = a[ok], b[ok]
    step = np.hypot(*np.diff(p[:, 1:3], axis=0).T)[ok]
    still = step < STANDING_SPEED_MPS * (b - a)
    dt = np.clip(np.minimum(b, t1_s) - np.maximum(a, t0_s), 0.0, None)     # within the window
    keep = dt > 0
    still, dt = still[keep], dt[keep]
    if not still.size:
        return 0.0, 0
    # runs of equal state: (standing?, duration)
    edges = np.flatnonzero(np.diff(still.astype(np.int8))) + 1
    starts = np.concatenate([[0], edges])
    runs = [[bool(still[i]), float(d)] for i, d in zip(starts, np.add.reduceat(dt, starts))]
    for k in range(1, len(runs) - 1):        # a twitch between two standing spells
        if not runs[k][0] and runs[k][1] < STOP_MIN_S and runs[k - 1][0] and runs[k + 1][0]:
            runs[k][0] = True
    merged = []
    for s, d in runs:
        if merged and merged[-1][0] == s:
            merged[-1][1] += d
        else:
            merged.append([s, d])
    stops = sum(1 for k, (s, d) in enumerate(merged) if s and k > 0 and d >= STOP_MIN_S)
    return float(dt[still].sum()), stops


FALSE_TAG_M = 0.5      # a confirmed tag farther than this from its true place counts as false


def tag_key(family, tag_id) -> tuple:
    """What an estimate and a true tag are matched by: the family's marker set and the id (None
    for the set of a tag without a family)."""
    if family is None:
        return None, tag_id
    from ..perception.families import marker_set
    return marker_set(family), int(tag_id)


def match_tags(true_tags: list, estimated: list) -> list:
    """For each estimate (family, id, x, y, z; family and z may be None), in order, (index of
    the true tag it matches, error m), or (None, None) for a false tag: the true tag of its
    marker set and id (the last one listed), if within FALSE_TAG_M; 3-D where both have a z,
    else in x-y."""
    index = {tag_key(f, i): k for k, (f, i, *_) in enumerate(true_tags)}
    out = []
    for f, i, x, y, z in estimated:
        k = index.get(tag_key(f, i))
        if k is not None:
            _, _, tx, ty, tz = true_tags[k]
            dz = 0.0 if z is None or tz is None else z - tz
            e = math.sqrt((x - tx) ** 2 + (y - ty) ** 2 + dz ** 2)
            if e <= FALSE_TAG_M:
                out.append((k, e))
                continue
        out.append((None, None))
    return out


def tag_metrics(true_tags: list, estimated: list) -> dict:
    """DESIGN §6's tag keys. ``true_tags``: (family, id, x, y, z) in the map frame (every tag
    the world places); ``estimated``: (family, id, x, y, z) of the confirmed tags, matched by
    ``match_tags``; one that matches none is false. Errors are 3-D distances (m)."""
    errors = [e for k, e in match_tags(list(true_tags), list(estimated)) if k is not None]
    placed = len({tag_key(f, i) for f, i, *_ in true_tags})
    return {"tags_placed": placed, "tags_confirmed": len(estimated),
            "tag_recall": round(len(errors) / placed, 4) if placed else None,
            "tag_error_median_m": round(float(np.median(errors)), 4) if errors else None,
            "tag_error_max_m": round(float(np.max(errors)), 4) if errors else None,
            "false_tags": len(estimated) - len(errors)}
