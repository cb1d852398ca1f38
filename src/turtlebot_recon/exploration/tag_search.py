"""The tag search (mission ``tags``): after the lidar's frontiers, drive to where the camera
sees the walls it has not seen yet, and to a better view of every tag not yet confirmed.

Seed 000 keeps a second map of what the camera has seen and sends the robot to the lidar map's
walls that the camera missed, with tags as priority goals. Here the camera map is
``perception.camera_coverage`` (a wall cell counts as seen when a camera frame saw it within
the range a tag stays readable and at no more than ``max_incidence_rad`` from its normal);
the walls that count are those facing free space the robot can reach. Each cycle:

1. A tag seen but not confirmed (tentative, or only ever ambiguous) gets a view first: the
   reachable cell nearest the point ``tag_view_m`` in front of it along its normal, facing it;
   the nearest such view by path cost.
2. Else, once the seen share of the walls is below ``seen_share_goal``: candidate cells on a
   ``view_spacing_m`` lattice of reachable cells within the readable range of an unseen wall;
   for each, the unseen wall cells it sees at readable range and angle (the same C++ ray
   cast as the coverage map, over all directions) and the heading whose field of view holds
   the most of them; the view with the most wall per metre of path (``gain / (cost +
   cost_offset_m)``), if it shows at least ``min_gain_m`` of wall.
3. Else nothing: the search is over.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from .. import _native
from ..config import positive, require
from ..geometry import inside, points_to_cells
from ..mapping.map_io import OCCUPIED_THRESH
from ..perception.camera_coverage import CameraCoverage, CoverageSettings
from ..perception.tracker import Glimpse
from ..robot import CameraSpec
from .context import Context


TAG_LOOKS = 2          # views reached per unconfirmed tag before it is left as it is


@dataclass(frozen=True)
class TagSearchSettings:
    seen_share_goal: float = 0.95     # the search ends once this share of the walls facing
                                      # reachable space has been seen (and no tag is unconfirmed)
    view_spacing_m: float = 0.3       # candidate views on a lattice this fine
    min_gain_m: float = 0.5           # a view must show at least this much unseen wall (m of face)
    cost_offset_m: float = 2.0        # score = wall seen (m) / (path cost (m) + this): far views
                                      # must show proportionally more
    max_candidates: int = 600         # the cheapest candidates evaluated per cycle
    tag_view_m: float = 1.0           # an unconfirmed tag is looked at from this far in front
    tag_snap_m: float = 0.6           # ... or from the reachable cell nearest that point within this
    fov_margin_rad: float = 0.1       # the chosen heading keeps the wall this far inside the view
    coverage: CoverageSettings = CoverageSettings()

    def validate(self, src: str) -> None:
        positive(src, self, "view_spacing_m", "min_gain_m", "tag_view_m", "tag_snap_m")
        require(0.0 < self.seen_share_goal <= 1.0, src, "seen_share_goal", "must be in (0, 1]")
        require(self.cost_offset_m >= 0, src, "cost_offset_m", "must be >= 0")
        require(isinstance(self.max_candidates, int) and self.max_candidates >= 1, src,
                "max_candidates", "must be an integer >= 1")
        require(self.fov_margin_rad >= 0, src, "fov_margin_rad", "must be >= 0")


@dataclass(frozen=True)
class View:
    """Where to drive and which way to face: (x, y) m and yaw rad in the map frame."""
    xy: Tuple[float, float]
    yaw: float
    kind: str                  # "tag" (an unconfirmed tag) | "wall"
    gain_m: float              # unseen wall it should show (m); 0 for a tag view
    label: str = ""            # for the log: the tag or the wall
    targets: Tuple = ()        # wall views: the (x, y) m of the wall cells it should show;
                               # tag views: (family, id)


class TagSearch:
    """The camera's coverage map and the choice of the next view (module docstring)."""

    def __init__(self, settings: TagSearchSettings, camera: CameraSpec):
        settings.validate("tag_search")
        self.s = settings
        self.camera = camera
        self.coverage = CameraCoverage.for_camera(camera, settings.coverage)
        self.seen_share: Optional[float] = None
        self.walls: Optional[np.ndarray] = None          # the last cycle's wall cells (bool)
        self.region: Optional[np.ndarray] = None         # ... and the free space they face
        self._looked_at = np.zeros((0, 2))               # wall cells views were reached for (m)
        self._tag_looks: dict = {}                       # (family, id) -> tag views reached

    def reached(self, view: View) -> None:
        """The robot reached ``view``: its wall cells are not offered again (what the camera
        did not see from there, an obstacle the lidar does not show hides), and a tag is
        looked at from up to ``TAG_LOOKS`` views."""
        if view.kind == "wall" and len(view.targets):
            self._looked_at = np.vstack([self._looked_at, np.asarray(view.targets, float)])
        elif view.kind == "tag":
            self._tag_looks[view.targets] = self._tag_looks.get(view.targets, 0) + 1

    def saw(self, occupancy: np.ndarray, resolution: float, origin: tuple, camera_pose: tuple) -> None:
        """A camera frame taken at ``camera_pose`` (x, y, yaw of the camera, map frame)."""
        self.coverage.update(occupancy, resolution, origin, camera_pose)

    def free_region(self, ctx: Context) -> np.ndarray:
        """The known free cells connected to where the robot can stand: the space whose walls
        count (a wall cell faces a cell of it)."""
        free = (ctx.occupancy >= 0) & (ctx.occupancy < OCCUPIED_THRESH)
        labels, _ = ndimage.label(free)
        keep = np.unique(labels[ctx.reachable & free])
        return np.isin(labels, keep[keep > 0])

    def unseen_walls(self, ctx: Context) -> np.ndarray:
        region = self.region = self.free_region(ctx)
        walls = self.coverage.wall_cells(ctx.occupancy, region)
        self.walls = walls
        seen = self.coverage.seen
        if seen is None or seen.shape != walls.shape:
            seen = np.zeros(walls.shape, np.uint8)
        unseen = walls & (seen == 0)
        total = int(walls.sum())
        self.seen_share = 1.0 if total == 0 else 1.0 - int(unseen.sum()) / total
        return unseen

    def choose(self, ctx: Context, unconfirmed: Sequence[Glimpse], blocked,
               pursued: Optional[View] = None) -> Optional[View]:
        """The next view, or None when the search is over. ``blocked(xy)``: a view there failed
        before (the goal book's blacklist). ``pursued``: the view being driven to, kept while
        it still has something to show (a tag still unconfirmed, at least ``min_gain_m`` of its
        wall still unseen) and still reachable: re-choosing every cycle would swap between
        views of similar worth and reach none."""
        unseen = self.unseen_walls(ctx)
        if pursued is not None and self._still_worth(pursued, ctx, unseen, unconfirmed):
            return pursued
        view = self.tag_view(ctx, unconfirmed, blocked)
        if view is not None:
            return view
        if self.seen_share >= self.s.seen_share_goal:
            return None
        return self._wall_view(ctx, unseen, blocked)

    def _still_worth(self, view: View, ctx: Context, unseen: np.ndarray, unconfirmed) -> bool:
        if not ctx.goal_ok(ctx.xy_to_cell(view.xy)):
            return False
        if view.kind == "tag":
            return any((t.family, t.id) == view.targets for t in unconfirmed)
        rows, cols = points_to_cells(np.asarray(view.targets, float).reshape(-1, 2), ctx.resolution, ctx.origin)
        ok = inside(rows, cols, unseen.shape)
        return int(unseen[rows[ok], cols[ok]].sum()) * ctx.resolution >= self.s.min_gain_m

    # ------------------------------------------------------------------------ views
    def tag_view(self, ctx: Context, unconfirmed: Sequence[Glimpse], blocked) -> Optional[View]:
        """The view of the nearest unconfirmed tag (by path) not looked at TAG_LOOKS times yet,
        from ``tag_view_m`` in front of it, or None."""
        best, best_cost = None, math.inf
        for t in unconfirmed:
            if self._tag_looks.get((t.family, t.id), 0) >= TAG_LOOKS:
                continue
            n = (math.cos(t.yaw), math.sin(t.yaw))
            cell = ctx.snap((t.x + self.s.tag_view_m * n[0], t.y + self.s.tag_view_m * n[1]), self.s.tag_snap_m)
            if cell is None:
                continue
            xy = ctx.cell_to_xy(cell)
            cost = float(ctx.cost_to_come[cell])
            if blocked(xy) or not cost < best_cost:
                continue
            best, best_cost = View(tuple(xy), math.atan2(t.y - xy[1], t.x - xy[0]), "tag", 0.0,
                                   f"tag {t.family} {t.id}", (t.family, t.id)), cost
        return best

    def _wall_view(self, ctx: Context, unseen: np.ndarray, blocked) -> Optional[View]:
        res = ctx.resolution
        if len(self._looked_at):
            rows, cols = points_to_cells(self._looked_at, res, ctx.origin)
            ok = inside(rows, cols, unseen.shape)
            unseen = unseen.copy()
            unseen[rows[ok], cols[ok]] = False
        if not unseen.any():
            return None
        reach_m = self.coverage.max_range_m
        near = ndimage.distance_transform_edt(~unseen) * res <= reach_m
        stride = max(1, int(round(self.s.view_spacing_m / res)))
        lattice = np.zeros_like(unseen)
        lattice[::stride, ::stride] = True
        cand = np.argwhere(ctx.reachable & near & lattice)
        if not len(cand):
            return None
        costs = ctx.cost_to_come[cand[:, 0], cand[:, 1]]
        order = np.argsort(costs, kind="stable")[:self.s.max_candidates]
        cand, costs = cand[order], costs[order]
        win = int(math.ceil(reach_m / res)) + 1
        half_fov = 0.5 * self.camera.hfov_rad - self.s.fov_margin_rad
        best, best_score = None, 0.0
        for (r, c), cost in zip(cand, costs):
            r0, c0 = max(r - win, 0), max(c - win, 0)
            sub = np.ascontiguousarray(ctx.occupancy[r0:r + win + 1, c0:c + win + 1])
            target = unseen[r0:r + win + 1, c0:c + win + 1]
            origin = (ctx.origin[0] + c0 * res, ctx.origin[1] + r0 * res)
            x, y = ctx.cell_to_xy((r, c))
            seen = None
            for yaw in (0.0, math.pi):        # all directions: two half planes
                seen = _native.camera_coverage(
                    sub, res, origin, (x, y, yaw), hfov_rad=math.pi, max_range_m=reach_m,
                    max_incidence_rad=self.s.coverage.max_incidence_rad,
                    occupied_threshold=OCCUPIED_THRESH, rays=self.s.coverage.rays,
                    seen=seen)
            rows, cols = np.nonzero((seen != 0) & target)
            if rows.size * res < self.s.min_gain_m:
                continue
            bearing = np.arctan2(origin[1] + (rows + 0.5) * res - y, origin[0] + (cols + 0.5) * res - x)
            yaw, count = best_window(bearing, half_fov)
            gain = count * res
            score = gain / (float(cost) + self.s.cost_offset_m)
            if gain >= self.s.min_gain_m and score > best_score and not blocked((x, y)):
                within = np.abs(np.remainder(bearing - yaw + math.pi, 2 * math.pi) - math.pi) <= half_fov
                xy = np.column_stack([origin[0] + (cols[within] + 0.5) * res,
                                      origin[1] + (rows[within] + 0.5) * res])
                best, best_score = View((x, y), yaw, "wall", gain, f"{gain:.1f} m of wall unseen",
                                        tuple(map(tuple, xy))), score
        return best


def best_window(bearing: np.ndarray, half_width: float) -> Tuple[float, int]:
    """The heading whose window of ±half_width holds the most of ``bearing`` (rad), and how
    many: each bearing tried as the window's left edge, on the circle."""
    b = np.sort(np.mod(bearing, 2 * math.pi))
    ext = np.concatenate([b, b + 2 * math.pi])
    ends = np.searchsorted(ext, b + 2 * half_width, side="right")
    counts = ends - np.arange(len(b))
    i = int(np.argmax(counts))
    centre = 0.5 * (ext[i] + ext[ends[i] - 1])
    return math.atan2(math.sin(centre), math.cos(centre)), int(min(counts[i], len(b)))
