"""Procedural simulator worlds (DESIGN.md section 4), ROS-free: numpy, OpenCV, PyYAML and
mapping.map_io (map_server's pixel values and thresholds), geometry (metres <-> cells).

A world is a map_server map (binary PGM + YAML) with the extra keys ``wall_height``, ``start``
and ``tags``.  Lengths are metres, angles radians.  World frame: x right, y up, origin at the
bottom-left corner of the image; pixel (row, col), row 0 at the top, has its centre at
x = ox + (col + 0.5) * res, y = oy + (H - row - 0.5) * res.  Every non-free pixel is solid.

    python -m turtlebot_recon.sim.worldgen OUTDIR [--only NAME]
"""
import argparse
import math
import os
import sys

import cv2
import numpy as np
import yaml

from .. import geometry
from ..mapping.map_io import (FREE_PX, OCCUPIED_PX, UNKNOWN_PX, YAML_FREE_THRESH,
                              YAML_OCCUPIED_THRESH, occupancy_classes)

FREE, OCCUPIED, UNKNOWN = FREE_PX, OCCUPIED_PX, UNKNOWN_PX   # map_saver pixel values
RES = 0.05                                  # m per pixel
WALL_HEIGHT = 0.5                           # m
TAG_Z = 0.25                                # m, marker centre height (mid-wall)
ARUCO_Z = 0.20                              # m, hand-placed ArUco centres: the waffle_pi camera
                                            # (0.104 m up, 48.8 deg vertical FOV) sees all of a
                                            # 0.10 m marker there from 0.33 m on (at 0.25 m: 0.44 m)
TAG_SIZES = {"tag36h11": 0.16, "aruco_6x6_100": 0.10}   # m, black-square edge
FACING = {"E": 0.0, "N": math.pi / 2, "W": math.pi, "S": -math.pi / 2}   # marker normal's yaw
ROBOT_RADIUS = 0.2                          # m, reachability checks
START_CLEARANCE = 0.4                       # m


# ------------------------------------------------------------------ drawing in metres
class Canvas:
    """An image addressed in building metres: world = building + ``margin`` (origin [0, 0, 0]).

    Starts all UNKNOWN (the outside, as map_saver leaves it).  Coordinates should lie on the
    0.05 m grid so that walls come out exactly as thick as asked.
    """

    def __init__(self, width, height, margin=0.5, res=RES):
        self.res, self.margin = res, margin
        self.img = np.full((round((height + 2 * margin) / res),
                            round((width + 2 * margin) / res)), UNKNOWN, np.uint8)

    def rect(self, x0, y0, x1, y1, value=OCCUPIED):
        """Fill the axis-aligned box [x0, x1] x [y0, y1] (m)."""
        h, m, r = self.img.shape[0], self.margin, self.res
        c0, c1 = round((min(x0, x1) + m) / r), round((max(x0, x1) + m) / r)
        r0, r1 = h - round((max(y0, y1) + m) / r), h - round((min(y0, y1) + m) / r)
        self.img[max(r0, 0):r1, max(c0, 0):c1] = value

    def circle(self, x, y, radius, value=OCCUPIED):
        """Fill every pixel whose centre is within ``radius`` (m) of (x, y)."""
        h, m, r = self.img.shape[0], self.margin, self.res
        cols = np.arange(max(0, int((x + m - radius) / r) - 1), int((x + m + radius) / r) + 2)
        rows = np.arange(max(0, h - int((y + m + radius) / r) - 2), h - int((y + m - radius) / r) + 1)
        px, py = px_to_world(rows[:, None], cols[None, :], self.img.shape, r, (-m, -m))
        # strictly inside (with float slack): a radius of whole pixels would otherwise grow
        # one-pixel nubs at N, E, S and W
        inside = (px - x) ** 2 + (py - y) ** 2 < (radius - 1e-6) ** 2
        self.img[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1][inside] = value

    def polygon(self, points, value=OCCUPIED, img=None):
        """Fill the polygon of vertices ``points`` [(x, y), ...] (m) in this canvas (or in
        ``img``, an array of its shape): every pixel whose centre is inside and the pixels its
        edges cross (OpenCV's fill, at 1/16 pixel precision)."""
        h, m, r = self.img.shape[0], self.margin, self.res
        pts = np.asarray(points, float)
        px = np.stack([(pts[:, 0] + m) / r - 0.5, h - (pts[:, 1] + m) / r - 0.5], axis=1)
        cv2.fillPoly(self.img if img is None else img, [np.round(px * 16).astype(np.int32)], int(value),
                     cv2.LINE_8, shift=4)

    def hwall(self, y, x0, x1, t=0.1):
        self.rect(x0, y - t / 2, x1, y + t / 2)

    def vwall(self, x, y0, y1, t=0.1):
        self.rect(x - t / 2, y0, x + t / 2, y1)

    def door(self, x, y, width=0.9, vertical=False, t=0.1):
        """Doorway centred on (x, y) through a horizontal (or vertical) wall; only the wall is carved."""
        w, d = (t / 2, width / 2) if vertical else (width / 2, t / 2)
        self.rect(x - w, y - d, x + w, y + d, FREE)

    def building(self, width, height, t=0.2):
        """Outer walls of thickness t, free inside."""
        self.rect(0, 0, width, height)
        self.rect(t, t, width - t, height - t, FREE)


# ------------------------------------------------------------------ geometry helpers
def free_mask(image, meta=None):
    """Boolean mask of free pixels, following map_server's thresholds (the map's YAML ``meta``)."""
    return occupancy_classes(image, meta or {}, "worldgen") == 0


def world_to_px(x, y, shape, res, origin):
    """(row, col) integer arrays of the pixels containing world points (x, y): the grid cells
    (row 0 at the bottom), rows flipped to the image's (row 0 at the top)."""
    rows, cols = geometry.points_to_cells(np.stack(np.broadcast_arrays(x, y), axis=-1), res, origin)
    return shape[0] - 1 - rows, cols


def px_to_world(row, col, shape, res, origin):
    """(x, y) arrays of the centres (m) of pixels (row, col): the grid cells (H - 1 - row, col)."""
    cells = np.stack(np.broadcast_arrays(shape[0] - 1 - np.asarray(row), col), axis=-1)
    xy = geometry.cells_to_points(cells, res, origin)
    return xy[..., 0], xy[..., 1]


def clearance(free, res):
    """Distance (m) from each pixel centre to the nearest non-free pixel's edge (0 if solid)."""
    d = cv2.distanceTransform(free.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return np.maximum(d * res - res / 2, 0.0)


def reachable(free, res, origin, start_xy, radius=ROBOT_RADIUS):
    """Pixels a disc robot of ``radius`` (m) can centre on, 8-connected to the start."""
    ok = (clearance(free, res) > radius).astype(np.uint8)
    _, labels = cv2.connectedComponents(ok, connectivity=8)
    r, c = world_to_px(start_xy[0], start_xy[1], free.shape, res, origin)
    return (labels == labels[r, c]) & (ok > 0)


def find_start(free, res, origin, prefer_xy, yaw=0.0, min_clear=START_CLEARANCE):
    """Pose [x, y, yaw] nearest ``prefer_xy`` with clearance >= min_clear, in the largest
    robot-reachable region (so never in a pocket cut off from the building)."""
    clear = clearance(free, res)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((clear > ROBOT_RADIUS).astype(np.uint8), connectivity=8)
    main = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    rows, cols = np.nonzero((labels == main) & (clear >= min_clear + res))   # + res: pixel rounding
    xs, ys = px_to_world(rows, cols, free.shape, res, origin)
    i = int(np.argmin((xs - prefer_xy[0]) ** 2 + (ys - prefer_xy[1]) ** 2))
    # The pixel's lower-left corner, not its centre: the robot's map (origin at the start pose)
    # then lies on the world's grid, and a wall face on a cell boundary of both.
    return [float(xs[i] - 0.5 * res), float(ys[i] - 0.5 * res), float(yaw)]


def _fps(points, k, rng, weight=None, group=None):
    """Farthest-point sampling of k indices; ``weight`` in (0, 1] scales each point's score,
    and points whose ``group`` (e.g. room) already holds a chosen point, or is 0 (unknown),
    score a quarter."""
    weight = np.ones(len(points)) if weight is None else weight
    group = np.zeros(len(points)) if group is None else np.asarray(group)
    best = np.flatnonzero(weight >= weight.max())
    chosen = [int(rng.choice(best))]
    dmin = np.linalg.norm(points - points[chosen[0]], axis=1)
    while len(chosen) < min(k, len(points)):
        used = np.isin(group, group[chosen]) | (group == 0)
        i = int(np.argmax(dmin * weight * np.where(used, 0.25, 1.0)))
        chosen.append(i)
        dmin = np.minimum(dmin, np.linalg.norm(points - points[i], axis=1))
    return chosen


# ------------------------------------------------------------------ tags
def check_tag(free, res, origin, x, y, yaw, size, support=None, reach=None, depth=0.6):
    """Return '' if a marker of edge ``size`` (m) at wall-surface point (x, y) facing ``yaw``
    is valid, else the reason.  Valid: axis-aligned yaw; along the full width size*1.3 the
    0.10 m behind the surface is solid (and ``support``, e.g. walls only, if given) and the
    ``depth`` metres in front are free; if ``reach`` is given, some pixel on the normal ray in
    front, in line of sight, is robot-reachable (so a camera can look at the tag)."""
    n = np.array([math.cos(yaw), math.sin(yaw)])
    if np.abs(n).max() < 0.999:
        return "yaw not axis-aligned"
    n = np.round(n)
    t = np.array([-n[1], n[0]])
    half = size * 1.3 / 2
    along = np.linspace(-half, half, max(3, int(math.ceil(2 * half / (res / 2))) + 1))

    def px(depths):   # depth offsets a quarter pixel off the edges, so none is ambiguous
        pts = np.array([x, y]) + depths[:, None, None] * n + along[None, :, None] * t
        r, c = world_to_px(pts[..., 0], pts[..., 1], free.shape, res, origin)
        on_grid = geometry.inside(r, c, free.shape)
        return np.clip(r, 0, free.shape[0] - 1), np.clip(c, 0, free.shape[1] - 1), on_grid

    r, c, inside = px(-np.arange(1, 8, 2) * res / 4)           # 0.0125 .. 0.0875 m behind
    if (free[r, c] & inside).any():
        return "not solid behind"
    if support is not None and not (support[r, c] & inside).all():
        return "not on a wall"
    r, c, inside = px(np.arange(res / 4, depth, res / 2))
    if not (free[r, c] & inside).all():
        return "front not free to %.2f m" % depth
    if reach is not None:
        r, c, inside = px(np.arange(res / 4, 3.0, res / 2))
        r, c, inside = r[:, len(along) // 2], c[:, len(along) // 2], inside[:, len(along) // 2]
        seen = np.cumprod(free[r, c] & inside).astype(bool)     # line of sight ends at a solid
        if not reach[r[seen], c[seen]].any():
            return "not visible from reachable space"
    return ""


def place_tags(free, res, origin, count, rng, families=("tag36h11",), support=None,
               reach=None, first_id=0, z=TAG_Z, depth=0.6):
    """Find ``count`` valid wall spots (see check_tag) spread far apart, families cycled.

    Candidates are the free pixels with a solid 4-neighbour; the tag sits on that shared
    pixel edge, centred on the pixel.  Spots are chosen by farthest-point sampling, with the
    score damped near the end of a straight wall run so that tags avoid room corners, and
    damped in rooms that already hold a tag.  Rooms are the parts of the space not in
    ``support`` (walls; furniture would split rooms) with more than 0.5 m clearance: that cuts
    doorways (<= 1.0 m) but keeps corridors.
    """
    size = max(TAG_SIZES[f] for f in families)          # every spot fits any family
    open_space = free if support is None else ~support
    _, rooms = cv2.connectedComponents((clearance(open_space, res) > 0.5).astype(np.uint8), connectivity=8)
    solid = np.pad(~free, 1, constant_values=True)
    h, w = free.shape
    even = (np.arange(h)[:, None] + np.arange(w)[None, :]) % 2 == 0  # spots 0.1 m apart on any wall
    pos, cent, room = [], [], []
    for yaw in (0.0, math.pi / 2, math.pi, -math.pi / 2):
        nx, ny = round(math.cos(yaw)), round(math.sin(yaw))
        dr, dc = ny, -nx                                # pixel offset of the solid neighbour
        cand = free & solid[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] & even   # every 0.1 m
        valid = np.zeros_like(cand)
        for r, c in zip(*np.nonzero(cand)):
            x, y = px_to_world(r, c, free.shape, res, origin)
            x, y = x - nx * res / 2, y - ny * res / 2
            valid[r, c] = not check_tag(free, res, origin, x, y, yaw, size, support, reach, depth)
        # Distance (m) to the nearer end of the run of valid spots along the wall, capped at 1 m.
        axis = 1 if nx == 0 else 0
        run = np.full(valid.shape, 10.0)
        for sign in (1, -1):
            steps, prev = np.zeros(valid.shape), valid.copy()
            for k in range(1, 11):
                prev &= np.roll(valid, 2 * sign * k, axis=axis)
                steps += prev
            run = np.minimum(run, steps)
        for r, c in zip(*np.nonzero(valid)):
            x, y = px_to_world(r, c, free.shape, res, origin)
            pos.append((x - nx * res / 2, y - ny * res / 2, yaw))
            cent.append(run[r, c] * 2 * res)
            ray = rooms[np.clip(r - ny * np.arange(60), 0, h - 1), np.clip(c + nx * np.arange(60), 0, w - 1)]
            room.append(ray[ray > 0][0] if (ray > 0).any() else 0)    # first room within 3 m
    if len(pos) < count:
        raise RuntimeError("only %d valid tag spots, %d wanted" % (len(pos), count))
    pos = np.array(pos)
    # Linear damping: a spot 0.1 m from a corner scores 1/8 of one 0.8 m along the wall.
    chosen = _fps(pos[:, :2], count, rng, np.clip(np.array(cent) / 0.8, 0.05, 1.0), room)
    return [make_tag(first_id + k, families[k % len(families)], *pos[i], z=z) for k, i in enumerate(chosen)]


def make_tag(tag_id, family, x, y, yaw, z=TAG_Z):
    """Tag dict as in the world YAML (values rounded to 4 decimals, + 0.0 turns -0.0 into 0.0)."""
    return {"id": int(tag_id), "family": family, "x": round(float(x), 4) + 0.0, "y": round(float(y), 4) + 0.0,
            "z": float(z), "yaw": round(float(yaw), 4) + 0.0, "size": TAG_SIZES[family]}


# ------------------------------------------------------------------ world assembly, checks, I/O
def make_meta(name, start, tags, res=RES):
    return {"image": name + ".pgm", "resolution": res, "origin": [0.0, 0.0, 0.0], "negate": 0,
            "occupied_thresh": YAML_OCCUPIED_THRESH, "free_thresh": YAML_FREE_THRESH, "mode": "trinary",
            "wall_height": WALL_HEIGHT, "start": [round(float(v), 4) + 0.0 for v in start], "tags": tags}


def _finish(cv, name, prefer, yaw, n_tags, rng, families=("tag36h11",), support=None, tags=None, extra=()):
    """Pick the start near building point ``prefer`` and place tags (sampled, or ``tags``),
    then the hand-placed ``extra`` ones (see hand_tags); returns (image, meta)."""
    origin = (0.0, 0.0)
    free = cv.img == FREE
    start = find_start(free, cv.res, origin, (prefer[0] + cv.margin, prefer[1] + cv.margin), yaw)
    reach = reachable(free, cv.res, origin, start[:2])
    if tags is None:
        tags = place_tags(free, cv.res, origin, n_tags, rng, families, support, reach)
    tags = list(tags) + hand_tags(cv, extra, support, reach, tags)
    return cv.img, make_meta(name, start, tags, cv.res)


def hand_tags(cv, spots, support, reach, existing=()):
    """Tags at hand-picked wall spots [(id, family, x, y, facing)], (x, y) the wall-surface
    point in building metres (``cv.margin`` is added), facing 'E', 'N', 'W' or 'S' (FACING).
    They come after the sampled tags, so those (and every rng draw) stay as they were: a
    world's existing tags and benchmarks do not move.  ArUco markers hang at ARUCO_Z.
    RuntimeError when a spot fails check_tag (on a wall of ``support``, free in front,
    visible from ``reach``) or repeats a (family, id) pair."""
    tags, seen = [], {(t["family"], t["id"]) for t in existing}
    for tag_id, family, x, y, facing in spots:
        z = ARUCO_Z if family.startswith("aruco_") else TAG_Z
        tag = make_tag(tag_id, family, x + cv.margin, y + cv.margin, FACING[facing], z=z)
        why = check_tag(cv.img == FREE, cv.res, (0.0, 0.0), tag["x"], tag["y"], tag["yaw"], tag["size"],
                        support, reach)
        if why or (family, tag_id) in seen:
            raise RuntimeError("hand-placed tag %s %d at (%.3f, %.3f): %s"
                               % (family, tag_id, tag["x"], tag["y"], why or "duplicate id"))
        seen.add((family, tag_id))
        tags.append(tag)
    return tags


def pockets(free, res, origin, reach, radius=ROBOT_RADIUS, min_pocket=1.0):
    """[(area m^2, x, y)] of the free regions larger than ``min_pocket`` that a disc of
    ``radius`` (m) centred on the ``reach`` pixels never covers (x, y: their centroids)."""
    k = 2 * int(math.ceil(radius / res)) + 1
    swept = cv2.dilate(reach.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) > 0
    n, labels, stats, cen = cv2.connectedComponentsWithStats((free & ~swept).astype(np.uint8), connectivity=8)
    big = [i for i in range(1, n) if stats[i, cv2.CC_STAT_AREA] * res * res > min_pocket]
    return [(stats[i, cv2.CC_STAT_AREA] * res * res, *px_to_world(cen[i][1], cen[i][0], free.shape, res, origin))
            for i in big]


def validate_world(image, meta, radius=ROBOT_RADIUS, min_pocket=1.0):
    """List of problems (empty = fine): start clearance, tag checks, and free regions of more
    than ``min_pocket`` m^2 that a robot of ``radius`` (m) can neither enter nor sweep."""
    res, origin = meta["resolution"], meta["origin"][:2]
    free, problems = free_mask(image, meta), []
    x, y, _ = meta["start"]
    r, c = world_to_px(x, y, image.shape, res, origin)
    if clearance(free, res)[r, c] < START_CLEARANCE:
        problems.append("start clearance below %.2f m" % START_CLEARANCE)
    reach = reachable(free, res, origin, (x, y), radius)
    for area, px, py in pockets(free, res, origin, reach, radius, min_pocket):
        problems.append("unreachable free area %.1f m^2 near (%.1f, %.1f)" % (area, px, py))
    ids = [t["id"] for t in meta["tags"]]
    if len(set(ids)) != len(ids):
        problems.append("duplicate tag ids")
    for t in meta["tags"]:
        why = check_tag(free, res, origin, t["x"], t["y"], t["yaw"], t["size"], reach=reach)
        if why:
            problems.append("tag %d: %s" % (t["id"], why))
    return problems


def write_world(directory, name, image, meta):
    """Write NAME.pgm (binary P5) and NAME.yaml (one flow-style tag per line); values are
    rounded to 4 decimals by make_meta / make_tag."""
    os.makedirs(directory, exist_ok=True)
    if not cv2.imwrite(os.path.join(directory, name + ".pgm"), image):
        raise IOError("cannot write %s.pgm" % name)
    meta = dict(meta, image=name + ".pgm")
    # default_flow_style=None: collections of scalars (origin, start, each tag) go inline.
    text = yaml.safe_dump(meta, default_flow_style=None, sort_keys=False, width=1000)
    with open(os.path.join(directory, name + ".yaml"), "w") as f:
        f.write(text)


# ------------------------------------------------------------------ the worlds
def house(seed=1):
    """About 15 x 10 m: hallway, living room, kitchen, 2 bathrooms, laundry, 2 bedrooms, study;
    11 tags: 9 sampled, an ArUco in a bedroom corner and one seen at grazing angles from the hallway."""
    rng = np.random.default_rng(seed)
    W, H = 15.0, 10.0
    cv = Canvas(W, H)
    cv.building(W, H)
    cv.hwall(4.25, 0.2, W - 0.2)                    # hallway y in [4.3, 5.7], 1.4 m wide
    cv.hwall(5.75, 0.2, W - 0.2)
    for x in (6.0, 10.0, 12.5):
        cv.vwall(x, 0.2, 4.25)                      # south: living | kitchen | bath | laundry
    for x in (4.5, 6.5, 10.5):
        cv.vwall(x, 5.75, H - 0.2)                  # north: bed 1 | bath 2 | bed 2 | study
    for x, y, w in ((3.0, 4.25, 1.0), (6.9, 4.25, 0.9), (11.2, 4.25, 0.8), (13.6, 4.25, 0.9),
                    (3.6, 5.75, 0.9), (5.5, 5.75, 0.8), (7.3, 5.75, 0.9), (11.3, 5.75, 0.9)):
        cv.door(x, y, w)
    cv.door(6.0, 3.4, 0.9, vertical=True)           # living room <-> kitchen
    walls = cv.img != FREE
    for box in ((1.8, 0.2, 4.0, 1.1),               # living: sofa, TV unit, coffee table, armchair
                (0.2, 1.4, 0.6, 2.9), (2.3, 1.9, 3.5, 2.5), (4.4, 2.3, 5.2, 3.1),
                (6.05, 0.2, 9.95, 0.8), (9.35, 0.8, 9.95, 2.8), (7.2, 2.0, 8.4, 2.8),  # kitchen
                (10.05, 0.2, 11.75, 0.95), (11.95, 2.0, 12.45, 3.1), (10.05, 2.0, 10.5, 2.7),  # bath
                (14.2, 0.2, 14.8, 1.4), (12.55, 0.2, 13.4, 0.6),                      # laundry
                (1.3, 7.8, 2.9, 9.8), (0.85, 9.35, 1.3, 9.8), (2.9, 9.35, 3.35, 9.8),  # bedroom 1
                (0.2, 5.8, 0.8, 7.0),
                (5.45, 8.8, 6.45, 9.8),                                               # bath 2
                (7.8, 7.8, 9.4, 9.8), (6.55, 8.0, 7.05, 9.0),                        # bedroom 2
                (12.6, 9.1, 14.8, 9.8), (14.4, 6.6, 14.8, 8.2)):                      # study
        cv.rect(*box)
    cv.circle(12.0, 7.4, 0.45)                      # study: round table
    cv.circle(0.45, 0.45, 0.25)                     # plant pots in corners
    cv.circle(10.2, 6.05, 0.25)
    cv.circle(14.55, 5.0, 0.25)                     # hallway end: plant pot
    scatter_circles(cv, 2, (0.2, 0.3), 0.75, rng)   # 0.75 m gaps keep 0.7 m passages
    extra = [(9, "aruco_6x6_100", 10.2, 9.8, "S"),   # corner: bedroom 2, 0.25 m from its east wall
             # grazing: hallway (1.4 m) south wall, between doors; the north wall's doors are
             # 1.55 m either side, so even through them it is seen 48 deg or more off its normal
             (10, "tag36h11", 9.3, 4.3, "N")]
    return _finish(cv, "house", (1.0, 5.0), 0.0, 9, rng, support=walls, extra=extra)


def scatter_circles(cv, n, radii, gap, rng, keep=()):
    """Add n discs of radius in ``radii`` (m) with >= ``gap`` m to any solid and to ``keep``
    points [(x, y)] (building coordinates)."""
    for _ in range(n):
        # whole pixels: other radii rasterise with one-pixel nubs at N, E, S, W
        radius = round(float(rng.uniform(*radii)) / cv.res) * cv.res
        clear = clearance(cv.img == FREE, cv.res)
        ok = clear >= radius + gap + cv.res                 # + res: pixel rounding of the disc
        rows, cols = np.nonzero(ok)
        xs, ys = px_to_world(rows, cols, ok.shape, cv.res, (-cv.margin, -cv.margin))
        for kx, ky in keep:
            far = (xs - kx) ** 2 + (ys - ky) ** 2 >= (radius + gap) ** 2
            xs, ys = xs[far], ys[far]
        if len(xs) == 0:
            raise RuntimeError("no room for another disc")
        i = rng.integers(len(xs))
        cv.circle(float(xs[i]), float(ys[i]), radius)


def maze(seed=2, n=11, cell=0.6, wall=0.1):
    """Perfect maze (seeded DFS) of n x n cells: corridors ``cell`` m, walls ``wall`` m, about
    8 x 8 m, a 2 x 2-cell start room (a 0.6 m corridor cannot give 0.4 m start clearance),
    tags on dead-end walls facing down their corridor and an ArUco in the start room's corner."""
    rng = np.random.default_rng(seed)
    pitch, size = cell + wall, n * (cell + wall) + wall
    cv = Canvas(size, size)
    cv.rect(0, 0, size, size)
    x0 = lambda i: wall + i * pitch                 # noqa: E731 - cell's low edge (m)
    openings = {(i, j): [] for i in range(n) for j in range(n)}
    stack, seen = [(0, 0)], {(0, 0)}
    while stack:
        i, j = stack[-1]
        nbrs = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if (i + di, j + dj) in openings and (i + di, j + dj) not in seen]
        if not nbrs:
            stack.pop()
            continue
        a, b = nbrs[rng.integers(len(nbrs))]
        openings[(i, j)].append((a - i, b - j))
        openings[(a, b)].append((i - a, j - b))
        seen.add((a, b))
        stack.append((a, b))
    for (i, j), dirs in openings.items():           # carve each cell and its east / north link
        for di, dj in dirs + [(0, 0)]:
            if di >= 0 and dj >= 0:
                cv.rect(x0(i), x0(j), x0(i + di) + cell, x0(j + dj) + cell, FREE)
    cv.rect(x0(0), x0(0), x0(1) + cell, x0(1) + cell, FREE)  # start room: cells (0..1, 0..1)
    ends = [(i, j, *d[0]) for (i, j), d in openings.items() if len(d) == 1 and max(i, j) > 1]
    pts = np.array([(x0(i), x0(j)) for i, j, _, _ in ends], float)
    tags = []
    for k, e in enumerate(_fps(pts, 4, rng)):
        i, j, di, dj = ends[e]                      # tag on the wall opposite the opening
        x = x0(i) + cell / 2 - di * cell / 2 + cv.margin
        y = x0(j) + cell / 2 - dj * cell / 2 + cv.margin
        tags.append(make_tag(k, "tag36h11", x, y, math.atan2(dj, di)))
    # yaw 0: a start yaw off the grid's axes rasterises the 0.6 m corridors diagonally in the
    # robot's map, and a waffle_pi (0.514 m swept disc) no longer fits through them
    extra = [(4, "aruco_6x6_100", wall, wall + 0.25, "E")]   # corner: start room, west wall
    return _finish(cv, "maze", (pitch, pitch), 0.0, 0, rng, tags=tags, extra=extra)


def office(seed=3):
    """32 x 21 m office: two 1.8 m corridors joined by three cross corridors, 20 offices and
    meeting rooms with 0.9 m doors, desks with chairs, 15 tags: 12 sampled (every third
    aruco_6x6_100), two seen at grazing angles from corridors and one in a corridor's corner."""
    rng = np.random.default_rng(seed)
    W, H, T = 32.0, 21.0, 0.2
    cv = Canvas(W, H)
    cv.building(W, H, T)
    for y in (5.95, 7.85, 13.15, 15.05):            # corridors y in [6.0, 7.8] and [13.2, 15.0]
        cv.hwall(y, T, W - T)
    for xa, xb in ((T, 2.0), (15.1, 16.9), (30.0, W - T)):   # cross corridors
        cv.rect(xa, 7.8, xb, 13.2, FREE)
        for x in (xa - 0.05, xb + 0.05):
            if T < x < W - T:
                cv.vwall(x, 7.8, 13.2)
    rooms = []                                      # (x0, y0, x1, y1, y of the door's wall)
    # Rows of rooms, given by wall centre lines; the end ones are existing walls (not drawn).
    south = [T - 0.05, 4.0, 8.0, 16.0, 20.0, 28.0, W - T + 0.05]  # 8-16, 20-28: meeting
    north = [T - 0.05] + [4.0 * k for k in range(1, 8)] + [W - T + 0.05]
    mid = [2.05, 6.35, 10.7, 15.05], [16.95, 21.3, 25.6, 29.95]
    for xs, y0, y1, dy in ((south, T, 5.9, (5.95,)), (north, 15.1, H - T, (15.05,)),
                           (mid[0], 7.9, 13.1, (7.85, 13.15)), (mid[1], 7.9, 13.1, (7.85, 13.15))):
        for x in xs[1:-1]:
            cv.vwall(x, y0, y1)
        for a, b in zip(xs[:-1], xs[1:]):
            rooms.append((a + 0.05, y0, b - 0.05, y1, dy[rng.integers(len(dy))]))
    for x0, y0, x1, y1, dy in rooms:
        xc = round(float(rng.uniform(x0 + 0.8, x1 - 0.8)) / 0.05) * 0.05
        cv.door(xc, dy, 0.9)
    walls = cv.img != FREE
    for x0, y0, x1, y1, dy in rooms:
        if x1 - x0 > 5.0:                           # meeting room: central table
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            cv.rect(cx - 1.6, cy - 0.6, cx + 1.6, cy + 0.6)
        else:
            _desks(cv, x0, y0, x1, y1, dy, rng)
    extra = [(12, "tag36h11", 15.1, 10.5, "E"),        # grazing: middle cross corridor's west wall
             # grazing: north corridor's north wall; across, the south wall is solid for 2.85 m
             # to the west and 7.2 m to the east (58 deg or more off its normal through a gap)
             (13, "aruco_6x6_100", 7.9, 15.0, "S"),
             (14, "tag36h11", 0.2, 6.25, "E")]          # corner: south corridor's west end
    return _finish(cv, "office", (1.1, 10.5), math.pi / 2, 12, rng,
                   ("tag36h11", "tag36h11", "aruco_6x6_100"), walls, extra=extra)


def _desks(cv, x0, y0, x1, y1, door_y, rng):
    """Desk (1.4 x 0.7 m) with a chair against the wall opposite the door, sometimes a second
    one against a side wall; chairs touch their desk so no slit pockets form."""
    far_top = door_y < y0                           # far wall is the top one
    s = -1 if far_top else 1                        # direction from the far wall into the room
    yf = y1 if far_top else y0
    dx = round(float(rng.uniform(x0 + 0.8, x1 - 2.2)) / 0.05) * 0.05
    cv.rect(dx, yf, dx + 1.4, yf + s * 0.7)
    cv.circle(dx + 0.7, yf + s * 0.9, 0.25)
    if rng.random() < 0.6:                          # side desk along the y axis
        left = dx > (x0 + x1) / 2 - 0.7             # on the side away from the first desk
        xw = x0 if left else x1
        sx = 1 if left else -1
        ya = yf + s * 1.6
        cv.rect(xw, ya, xw + sx * 0.7, ya + s * 1.4)
        cv.circle(xw + sx * 0.9, ya + s * 0.7, 0.25)


def arena(seed=4, n_cyl=16):
    """One 15 x 15 m room with ``n_cyl`` cylinders (radius 0.15-0.4 m), >= 0.8 m gaps; 8 tags:
    6 sampled, an ArUco in the south-west corner and a tag36h11 in the north-east one."""
    rng = np.random.default_rng(seed)
    W, T = 15.4, 0.2
    cv = Canvas(W, W)
    cv.building(W, W, T)
    walls = cv.img != FREE
    scatter_circles(cv, n_cyl, (0.15, 0.4), 0.8, rng, keep=[(W / 2, W / 2)])
    extra = [(6, "aruco_6x6_100", T, T + 0.25, "E"),          # corner: SW, west wall
             (7, "tag36h11", W - T - 0.25, W - T, "S")]      # corner: NE, north wall
    return _finish(cv, "arena", (W / 2, W / 2), 0.0, 6, rng, support=walls, extra=extra)


def box_outline(x, y, width, depth, turn=0.0):
    """Vertices (m) of a ``width`` x ``depth`` box centred on (x, y), turned by ``turn`` rad."""
    u, v = np.array([-1, 1, 1, -1]) * width / 2, np.array([-1, -1, 1, 1]) * depth / 2
    c, s = math.cos(turn), math.sin(turn)
    return np.stack([x + c * u - s * v, y + s * u + c * v], axis=1)


def ellipse_outline(x, y, rx, ry, turn=0.0, n=24):
    """Vertices (m) of an ellipse of semi-axes ``rx``, ``ry`` centred on (x, y), turned by ``turn``."""
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    u, v = rx * np.cos(a), ry * np.sin(a)
    c, s = math.cos(turn), math.sin(turn)
    return np.stack([x + c * u - s * v, y + s * u + c * v], axis=1)


def rock_outline(rng, x, y, size):
    """Vertices (m) of one irregular obstacle about ``size`` m across centred on (x, y): a
    jagged rock (7-11 vertices at 0.65-1.0 of the radius), an ellipse or a turned slab."""
    kind, r, turn = rng.integers(3), size / 2, rng.uniform(0, math.pi)
    if kind == 1:
        return ellipse_outline(x, y, r, r * rng.uniform(0.45, 0.9), turn)
    if kind == 2:
        return box_outline(x, y, size * rng.uniform(0.8, 1.0), size * rng.uniform(0.35, 0.7), turn)
    a = np.sort(rng.uniform(0, 2 * math.pi, int(rng.integers(7, 12))))
    rho = r * rng.uniform(0.65, 1.0, len(a))
    return np.stack([x + rho * np.cos(a), y + rho * np.sin(a)], axis=1)


def pack_rocks(cv, rng, box, gaps, sizes, start, keep=(), trials=20000, pocket_m2=0.5):
    """Pack irregular obstacles (rock_outline, ``sizes`` m across) centred in ``box``
    (x0, y0, x1, y1, building m): each leaves a gap of gaps[0]..gaps[1] m to the nearest solid
    (walls or earlier rocks), so the field grows from the walls until no more fit.  ``keep``:
    [(x, y, r)] discs left free.  A rock that would leave a free pocket over ``pocket_m2`` that
    a ROBOT_RADIUS disc driven from ``start`` (world x, y) never covers is skipped
    (validate_world's check).  Returns how many were placed."""
    h, w = cv.img.shape
    origin = (-cv.margin, -cv.margin)
    xs, ys = px_to_world(np.arange(h)[:, None], np.arange(w)[None, :], (h, w), cv.res, origin)
    reserved = np.zeros((h, w), bool)
    for kx, ky, kr in keep:
        reserved |= (xs - kx) ** 2 + (ys - ky) ** 2 < kr ** 2
    scratch = np.zeros((h, w), np.uint8)            # each candidate drawn here first
    placed, gap = 0, None
    for _ in range(trials):
        if gap is None:       # free gap (m) beside each pixel: to the nearest solid pixel centre, less one pixel
            free = cv.img == FREE
            gap = (cv2.distanceTransform(free.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE) - 1) * cv.res
        outline = rock_outline(rng, *rng.uniform(box[:2], box[2:]), rng.uniform(*sizes))
        r1, c0 = world_to_px(*outline.min(axis=0), (h, w), cv.res, origin)   # image rows run down
        r0, c1 = world_to_px(*outline.max(axis=0), (h, w), cv.res, origin)
        rows, cols = slice(max(r0 - 2, 0), r1 + 3), slice(max(c0 - 2, 0), c1 + 3)
        scratch[rows, cols] = 0
        cv.polygon(outline, 1, scratch)
        mask = scratch[rows, cols] > 0
        if (mask & reserved[rows, cols]).any() or not gaps[0] <= gap[rows, cols][mask].min() <= gaps[1]:
            continue
        after = free.copy()
        after[rows, cols] &= ~mask
        if pockets(after, cv.res, origin, reachable(after, cv.res, origin, start), ROBOT_RADIUS, pocket_m2):
            continue
        cv.img[rows, cols][mask] = OCCUPIED
        placed, gap = placed + 1, None
    return placed


def garden(seed=5):
    """About 12 x 10 m: a rock garden (8 x 10 m) packed with irregular rocks, ellipses and
    turned slabs 0.2-1.1 m across with 0.4-0.8 m gaps about a winding 0.9 m path, and on its
    east side a shed (0.8 m door) and a greenhouse (0.5 m door, rocks with 0.5-0.9 m gaps)
    joined by a 0.45 m door; 8 tags: 6 sampled, an ArUco in the shed's north-west corner and
    a tag36h11 in the garden's."""
    rng = np.random.default_rng(seed)
    W, H, T = 12.0, 10.0, 0.2
    cv = Canvas(W, H)
    cv.building(W, H, T)
    cv.vwall(8.05, T, H - T)                        # garden x in [0.2, 8.0]
    cv.hwall(4.95, 8.1, W - T)                      # shed y in [0.2, 4.9], greenhouse [5.0, 9.8]
    doors = ((8.05, 2.5, 0.8, True), (8.05, 7.3, 0.5, True), (10.025, 4.95, 0.45, False))
    for x, y, width, vertical in doors:
        cv.door(x, y, width, vertical)
    walls = cv.img != FREE
    for box in ((11.2, 0.2, 11.8, 2.0), (8.1, 0.2, 9.3, 0.7)):      # shed: shelves
        cv.rect(*box)
    cv.polygon(box_outline(10.0, 3.1, 1.1, 0.55, 0.45))             # shed: a turned workbench
    start = (1.0 + cv.margin, 5.0 + cv.margin)     # world metres (the margin added)
    keep = [(1.0, 5.0, 0.9)] + [(x, y, 0.6) for x, y, _, _ in doors]
    # A 0.9 m garden path winds from the start to both doors; off it, only 0.4-0.8 m gaps.
    for a, b in (((1.0, 5.0), (3.0, 4.0)), ((3.0, 4.0), (5.5, 3.2)), ((5.5, 3.2), (8.0, 2.5)),
                 ((5.5, 3.2), (6.2, 6.0)), ((6.2, 6.0), (8.0, 7.3))):
        keep += [(*np.add(a, f * np.subtract(b, a)), 0.45) for f in np.linspace(0, 1, 30)]
    for sizes in ((0.4, 1.1), (0.2, 0.45)):         # boulders, then stones in the holes they leave
        pack_rocks(cv, rng, (T, T, 8.0, H - T), (0.4, 0.8), sizes, start, keep)
    pack_rocks(cv, rng, (8.1, 5.0, W - T, H - T), (0.5, 0.9), (0.3, 0.7), start, keep, trials=1000)
    extra = [(6, "aruco_6x6_100", 8.35, 4.9, "S"),     # corner: shed NW, north wall
             (7, "tag36h11", T, H - T - 0.25, "E")]      # corner: garden NW, west wall
    return _finish(cv, "garden", (1.0, 5.0), 0.0, 6, rng, support=walls, extra=extra)


def doors(seed=6):
    """16 x 11 m: a 1.1 m corridor between two rows of rooms from 2 x 2 m closets to 6 x 4.7 m
    halls (four behind other rooms), behind 0.45-0.6 m doors (seven of 0.45 m), furniture,
    12 tags: 10 sampled (every third aruco_6x6_100), an ArUco seen at grazing angles from the
    corridor and a tag36h11 in a room's corner."""
    rng = np.random.default_rng(seed)
    W, H, T = 16.0, 11.0, 0.2
    cv = Canvas(W, H)
    cv.building(W, H, T)
    cv.hwall(4.95, T, W - T)                        # corridor y in [5.0, 6.1]
    cv.hwall(6.15, T, W - T)
    for x in (6.25, 9.85, 13.45):                   # south: hall | room + closet | room | 2 closets
        cv.vwall(x, T, 4.95)
    for x in (2.25, 8.35, 11.95):                   # north: 2 closets | hall | room | room + closet
        cv.vwall(x, 6.15, H - T)
    cv.vwall(7.75, T, 2.8)                          # closet in the south room, x [7.8, 9.8]
    cv.hwall(2.75, 7.7, 9.8)
    cv.hwall(2.55, 13.5, W - T)                     # south-east closets, y [0.2, 2.5] and [2.6, 4.9]
    cv.hwall(8.75, T, 2.2)                          # north-west closets
    cv.vwall(13.75, 8.2, H - T)                     # closet in the north-east room, y [8.3, 10.8]
    cv.hwall(8.25, 13.7, W - T)
    # Door centres put both edges on the 0.05 m grid (a 0.45 m door centred on x.x25 or x.x75).
    for x, y, width in ((3.0, 4.95, 0.6), (7.025, 4.95, 0.45), (8.825, 2.75, 0.45), (11.5, 4.95, 0.5),
                        (14.625, 4.95, 0.5), (15.125, 2.55, 0.45), (1.225, 6.15, 0.45), (4.025, 6.15, 0.55),
                        (7.525, 6.15, 0.45), (10.0, 6.15, 0.5), (12.525, 6.15, 0.45)):
        cv.door(x, y, width)
    for x, y, width in ((2.25, 9.825, 0.45), (13.75, 9.525, 0.55)):
        cv.door(x, y, width, vertical=True)
    walls = cv.img != FREE
    for box in ((1.5, 1.5, 3.5, 2.4), (0.2, 2.8, 0.6, 4.6),           # hall S: table, shelf
                (8.6, 4.3, 9.8, 4.9), (9.4, 0.2, 9.8, 1.6),           # room + closet S
                (9.9, 0.2, 11.4, 2.2), (12.8, 0.2, 13.4, 1.4),        # room S: bed, wardrobe
                (13.5, 0.2, 15.8, 0.6),                               # closet SE: shelf
                (0.2, 7.0, 0.6, 8.7), (1.6, 10.2, 2.2, 10.8),         # closets NW
                (4.0, 10.2, 6.5, 10.8), (7.9, 7.5, 8.3, 9.5),         # hall N: sofa, cabinet
                (8.4, 10.1, 9.8, 10.8),                               # room N: desk
                (14.6, 6.2, 15.8, 6.9), (12.0, 9.6, 12.5, 10.8), (15.4, 8.3, 15.8, 10.8)):  # room NE
        cv.rect(*box)
    for x, y, r in ((2.5, 1.3, 0.2), (3.0, 2.6, 0.2), (15.4, 4.5, 0.25), (11.2, 7.5, 0.3), (15.0, 7.1, 0.2),
                    (4.6, 8.0, 0.25), (6.0, 8.0, 0.25)):             # chairs, bins, plants
        cv.circle(x, y, r)
    cv.polygon(ellipse_outline(5.3, 8.9, 1.2, 0.6))                      # hall N: oval table
    for outline in (box_outline(5.0, 1.2, 1.2, 0.6, 0.35), box_outline(12.2, 3.3, 0.5, 0.5, 0.6),  # piano, chair
                    box_outline(9.4, 8.5, 0.8, 0.5, 0.5), box_outline(10.9, 9.6, 0.6, 0.6, 0.8)):  # crates
        cv.polygon(outline)
    # grazing: the corridor's north wall, between doors; the south wall's doors are 2.0 m
    # either side (61 deg off its normal through them)
    extra = [(10, "aruco_6x6_100", 9.25, 6.1, "S"),
             (11, "tag36h11", 9.9, 4.65, "E")]           # corner: room S's north-west, west wall
    return _finish(cv, "doors", (8.0, 5.55), 0.0, 10, rng, ("tag36h11", "tag36h11", "aruco_6x6_100"), walls,
                   extra=extra)


def cluttered(seed=7):
    """25 x 17 m, cluttered (issue 30's held-out benchmark world, for both TurtleBot 3s): a rock
    field of irregular rocks 0.2-1.1 m across with 0.45-0.8 m gaps fills the west and middle;
    across it runs a hall at 56 deg (2.5 m wide) whose long walls have 0.3 m slits, too narrow
    for either robot's planner (the burger needs 0.35 m), so most of it is seen through them;
    its only door, 0.45 m, is at its south end; on the east, three rooms behind 0.45 m doors
    (one with a closet behind another) with furniture. A 1 m path winds through the field from
    the start to the hall's door and the rooms' doors, so the waffle_pi (which turns in place
    only where its 0.51 m turning disc fits) can reach them; off it only the rocks' gaps lead.
    8 tags, sampled on the walls."""
    rng = np.random.default_rng(seed)
    W, H, T = 25.0, 17.0, 0.2
    cv = Canvas(W, H)
    cv.building(W, H, T)
    xr = 18.05                                      # rooms x in [18.1, 24.8]
    cv.vwall(xr, T, H - T)
    cv.hwall(5.75, xr, W - T)                       # rooms y in [0.2, 5.7], [5.8, 11.2], [11.3, 16.8]
    cv.hwall(11.25, xr, W - T)
    cv.vwall(22.05, 5.8, 8.45)                      # closet in the middle room, x [22.1, 24.8], y [5.8, 8.4]
    cv.hwall(8.45, 22.05, W - T)
    # 0.45 m doors centred on x.x25, so that both edges lie on the 0.05 m grid
    for y in (3.025, 8.525, 14.025):
        cv.door(xr, y, 0.45, vertical=True)
    cv.door(22.05, 7.025, 0.45, vertical=True)
    # The hall: a parallelogram with horizontal ends at y 1.5 and 15.5, its long walls 0.15 m
    # thick (0.18 m along x at 56 deg).
    inner = np.array([(4.0, 1.55), (7.0, 1.55), (16.5, 15.45), (13.5, 15.45)])
    cv.polygon([(3.82, 1.45), (7.18, 1.45), (16.68, 15.55), (13.32, 15.55)])
    cv.polygon(inner, FREE)
    cv.door(5.525, 1.5, 0.45, t=0.2)                # t: the polygon's edge pixels widen the wall
    u = np.subtract(inner[2], inner[1]) / np.linalg.norm(np.subtract(inner[2], inner[1]))
    n = np.array([u[1], -u[0]])                     # the east wall's outward normal
    slits = []
    for a, b, out in ((inner[0], inner[3], -n), (inner[1], inner[2], n)):   # west wall, east wall
        for f in (0.25, 0.5, 0.75):
            c = np.add(a, f * np.subtract(b, a)) + out * 0.09             # on the wall's centre line
            cv.polygon([c + su * 0.15 * u + sn * 0.2 * out for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))], FREE)
            slits.append(tuple(c + out * 0.7))
    walls = cv.img != FREE
    for box in ((20.0, 1.5, 21.5, 2.5), (24.3, 0.2, W - T, 3.0),          # room S: table, shelf
                (18.6, 10.2, 20.6, 11.2),                                 # room M: bed
                (20.5, 16.1, 22.5, H - T), (24.3, 12.0, W - T, 14.5)):    # room N: desk, cabinet
        cv.rect(*box)
    cv.circle(21.5, 15.7, 0.25)                                           # room N: chair
    cv.polygon(box_outline(23.0, 9.9, 0.9, 0.6, 0.5))                      # room M: a turned crate
    start = (1.0 + cv.margin, 8.5 + cv.margin)     # world metres (the margin added)
    keep = [(1.0, 8.5, 0.9), (5.525, 1.0, 0.6)] + [(x, y, 0.6) for x, y in slits]
    keep += [(xr - 0.7, y, 0.6) for y in (3.025, 8.525, 14.025)]
    # A 1 m path winds from the start round the hall (south and north of it) past every door.
    route = ((1.0, 8.5), (2.0, 4.0), (2.5, 0.85), (9.0, 0.85), (12.0, 3.5), (17.35, 3.025), (14.5, 6.0),
             (17.35, 8.525), (15.5, 11.0), (17.35, 14.025), (16.0, 16.2), (10.0, 16.2), (5.0, 13.5),
             (1.0, 8.5))
    for a, b in zip(route[:-1], route[1:]):
        steps = int(np.ceil(np.hypot(*np.subtract(b, a)) / 0.2)) + 1
        keep += [(*np.add(a, f * np.subtract(b, a)), 0.5) for f in np.linspace(0, 1, steps)]
    hall = np.zeros_like(walls)                     # no rocks in the hall: solid while packing
    cv.polygon(inner, 1, hall.view(np.uint8))
    hall &= cv.img == FREE
    cv.img[hall] = OCCUPIED
    for sizes in ((0.4, 1.1), (0.2, 0.45)):         # boulders, then stones in the holes they leave
        pack_rocks(cv, rng, (T, T, xr - 0.3, H - T), (0.45, 0.8), sizes, start, keep)
    cv.img[hall] = FREE
    return _finish(cv, "cluttered", (1.0, 8.5), 0.0, 8, rng, support=walls)


def warehouse(rows=1700, cols=1000, seed=0):
    """A rows x cols map at 0.05 m (default 85 x 50 m) for load-time benchmarks: rack rows,
    pillars, a loading dock with pallets, and unknown (205) blocks.  Returns (image, meta)."""
    rng = np.random.default_rng(seed)
    m = 0.5
    W, H = cols * RES - 2 * m, rows * RES - 2 * m
    cv = Canvas(W, H, margin=m)
    cv.building(W, H, 0.3)
    dock = 12.0                                     # loading area at the south end
    x = 3.0
    while x + 2.2 < W - 3.0:                        # double racks 2.2 m deep, 3 m aisles
        y = dock
        while y + 16.0 < H - 3.0:                   # 16 m rack runs, 4 m cross aisles
            cv.rect(x, y, x + 2.2, y + 16.0)
            if rng.random() < 0.3:                  # part of the rack never scanned
                cv.rect(x + 0.3, y + 4.0, x + 1.9, y + 10.0, UNKNOWN)
            cv.rect(x + 0.85, y + 17.75, x + 1.35, y + 18.25)   # pillar in the cross aisle
            y += 20.0
        x += 5.2
    for _ in range(25):                             # pallets on the dock
        px, py = rng.uniform(2.0, W - 4.0), rng.uniform(1.5, dock - 3.0)
        cv.rect(px, py, px + 1.2, py + 1.0)
    for _ in range(6):                              # unmapped patches
        px, py = rng.uniform(2.0, W - 6.0), rng.uniform(1.5, H - 6.0)
        cv.rect(px, py, px + rng.uniform(1.0, 4.0), py + rng.uniform(1.0, 4.0), UNKNOWN)
    cv.rect(W - 10.3, 0.3, W - 0.3, 8.3, UNKNOWN)   # closed dock office, never seen inside
    cv.hwall(8.3, W - 10.4, W - 0.3, 0.2)
    cv.vwall(W - 10.3, 0.3, 8.4, 0.2)
    return _finish(cv, "warehouse", (W / 2, dock / 2), math.pi / 2, 10, rng)


def warehouse_floor():
    """``warehouse`` at 50 x 35 m (1,302 m^2 free), the size of issue 30's real warehouse (1,280
    m^2): the large open floor of bench-explore's FULL=1 sweep."""
    return warehouse(rows=1000, cols=700)


WORLDS = {"house": house, "maze": maze, "office": office, "arena": arena, "garden": garden, "doors": doors,
          "cluttered": cluttered, "warehouse": warehouse_floor}


def main(argv=None):
    ap = argparse.ArgumentParser(description="Write the shipped simulator worlds.")
    ap.add_argument("outdir")
    ap.add_argument("--only", choices=sorted(WORLDS))
    args = ap.parse_args(argv)
    bad = 0
    for name in [args.only] if args.only else list(WORLDS):
        image, meta = WORLDS[name]()
        write_world(args.outdir, name, image, meta)
        problems = validate_world(image, meta)
        bad += len(problems)
        print("%-6s %4dx%-4d px  %5.1f x %4.1f m  %2d tags  %s" % (
            name, image.shape[1], image.shape[0], image.shape[1] * RES, image.shape[0] * RES,
            len(meta["tags"]), "; ".join(problems) or "ok"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
