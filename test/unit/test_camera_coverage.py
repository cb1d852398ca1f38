"""Camera coverage: the wall cells the camera has seen well enough to read a tag on them.

``_native.camera_coverage`` (C++) on hand-drawn maps with the expected cells worked out in the
comments, and against a plain-Python reference (same rays, same traversal, same wall
direction) on random maps with fixed seeds; then ``CameraCoverage`` across growing maps.

Maps are int8 ROS occupancy, row 0 = smallest y, RES = 0.05 m; cell (r, c) spans
x in [c RES, (c + 1) RES), y in [r RES, (r + 1) RES) with the origin at (0, 0).

Timing (not a test; one call, -O3, one core of this container's AMD EPYC): 400 x 400 grid,
border walls and 0.2 % random wall cells, hfov 62.2 deg, max range 4.24 m (waffle_pi, 16 cm
tags at 20 px): 640 rays 0.13 ms, the automatic 186 rays 0.04 ms. 640 rays across an open
20 x 20 m room with a 20 m range (rays of up to ~400 cells): 0.46 ms. CameraCoverage.update
on the same grid, unchanged since the last call (mask updated in place): 0.04 ms.
"""
import logging
import math
from functools import partial

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.perception.camera_coverage import (WALL_SEEN, WALL_UNSEEN, CameraCoverage,
                                                        CoverageSettings)
from turtlebot_recon.robot import CameraSpec

from conftest import grid_traversal

RES = 0.05
# the binding takes every argument: map_server's occupied threshold and CoverageSettings' rays unless a
# test gives its own
camera_coverage = partial(_native.camera_coverage, occupied_threshold=OCCUPIED_THRESH, rays=CoverageSettings().rays)
UNKNOWN, FREE, WALL = -1, 0, 100
DEG = math.pi / 180


def square_room(n=80, wall=2):
    """n x n cells (4 x 4 m), walls `wall` cells thick: free cells are rows/cols wall..n-wall-1,
    so the east wall's face column is n - wall (x = 3.9 m for n = 80)."""
    occ = np.full((n, n), WALL, np.int8)
    occ[wall:n - wall, wall:n - wall] = FREE
    return occ


def coverage(occ, pose, hfov_deg=60.0, max_range_m=4.0, max_incidence_deg=60.0, **kw):
    return camera_coverage(occ, RES, (0.0, 0.0), pose, hfov_deg * DEG, max_range_m,
                                   max_incidence_deg * DEG, **kw)


def cells(mask):
    return {tuple(rc) for rc in np.argwhere(mask)}


# ------------------------------------------------------------------------ the C++ function

def test_room_sees_the_east_wall_inside_the_field_of_view_only():
    occ = square_room()
    seen = coverage(occ, (2.0, 2.0, 0.0))
    # Face of the east wall: x = 3.9 m, 1.9 m ahead. The fov edges (+-30 deg) meet it at
    # y = 2 -+ 1.9 tan 30 = 0.903 / 3.097 m: rows floor(18.06) = 18 .. floor(61.94) = 61.
    # Nothing else: rays stop on the face column, west / north / south walls are outside.
    assert seen.dtype == np.uint8 and seen.shape == occ.shape
    assert cells(seen) == {(r, 78) for r in range(18, 62)}


def test_a_wall_beyond_max_range_is_not_seen():
    occ = square_room()
    assert not coverage(occ, (2.0, 2.0, 0.0), max_range_m=1.85).any()   # face at 1.9 m
    # 1.95 m: a ray at angle a enters the face at 1.9 / cos a <= 1.95 -> |a| <= 13.1 deg, so
    # |y - 2| <= 1.9 tan 13.1 deg = 0.442 m: rows floor(31.2) = 31 .. floor(48.8) = 48.
    rows = sorted(r for r, c in cells(coverage(occ, (2.0, 2.0, 0.0), max_range_m=1.95)))
    assert rows[0] in (31, 32) and rows[-1] in (47, 48)
    assert set(range(32, 48)) <= set(rows)


def test_grazing_view_is_not_seen_but_the_same_wall_face_on_is():
    # A 10 m wall along x (row 30: face at y = 1.5 m), free below, unknown above.
    occ = np.full((40, 200), FREE, np.int8)
    occ[30] = WALL
    occ[31:] = UNKNOWN
    camera = (1.0, 0.5)            # 1.0 m below the face
    # Looking along the wall (yaw 0, +-30 deg): a ray at a > 0 meets the face at incidence
    # 90 - a >= 60 deg, and within 4 m only for a >= asin(1 / 4) = 14.5 deg: 60 .. 75.5 deg.
    along = coverage(occ, (*camera, 0.0), max_incidence_deg=50.0)
    assert not along.any()
    # Allowing 70 deg: the rays with a >= 20 deg, x <= 1 + 1 / tan 20 deg = 3.75 m, and no
    # farther than the a = 30 deg ray, x >= 1 + 1 / tan 30 deg = 2.73 m (cols 54 .. 75).
    oblique = cells(coverage(occ, (*camera, 0.0), max_incidence_deg=70.0))
    assert {c for r, c in oblique} >= set(range(55, 75))
    assert {r for r, c in oblique} == {30} and min(c for r, c in oblique) >= 54
    assert max(c for r, c in oblique) <= 75
    # Face on (yaw 90 deg): incidence <= 30 deg, x = 1 -+ tan 30 deg: cols 8 .. 31.
    face_on = cells(coverage(occ, (*camera, 90 * DEG), max_incidence_deg=50.0))
    assert {c for r, c in face_on} == set(range(8, 32)) and {r for r, c in face_on} == {30}


def test_a_diagonal_wall_is_seen_face_on_and_does_not_leak():
    # A one-cell-thick diagonal wall, cells (i, i), with an east wall behind it at col 70.
    occ = np.full((80, 80), FREE, np.int8)
    idx = np.arange(80)
    occ[idx, idx] = WALL
    occ[:, 70:] = WALL
    # Camera on the y < x side of the diagonal: at (2.5, 1.0) m, cell (20, 50). The
    # diagonal's normal points along (-1, 1) / sqrt 2: yaw 135 deg looks at it face on, and
    # with max incidence 10 deg and a 10 deg fov every ray qualifies.
    seen = cells(coverage(occ, (2.5, 1.0, 135 * DEG), hfov_deg=10.0, max_incidence_deg=10.0))
    assert seen and all(r == c for r, c in seen)
    # Aimed along the wall's direction at 45 deg incidence, the same cells do not count.
    assert not coverage(occ, (2.5, 1.0, 90 * DEG), hfov_deg=10.0, max_incidence_deg=10.0).any()
    # From the other side, (1.0, 2.5) m, rays at -35 .. -5 deg all cross the diagonal before
    # the east wall (at x = 3.5 m the -5 deg ray is at y = 2.28 < 3.5). The 4-connected ray
    # walk cannot pass between two diagonal neighbours: only diagonal cells are seen.
    behind = cells(coverage(occ, (1.0, 2.5, -20 * DEG), hfov_deg=30.0, max_incidence_deg=90.0))
    assert len(behind) > 10 and all(r == c for r, c in behind)


def test_an_occluding_pillar_shadows_the_wall_behind_it():
    occ = square_room()
    occ[39:41, 50:52] = WALL            # 2 x 2 pillar, x 2.5 .. 2.6, y 1.95 .. 2.05 m
    seen = coverage(occ, (2.0, 2.0, 0.0))
    # Its near corners as seen from (2, 2) bound the shadow on the face x = 3.9: y = 2 +-
    # 0.05 * 1.9 / 0.5 = 2 +- 0.19 m. Rows 37 .. 42 (y 1.85 .. 2.15) lie wholly inside it;
    # rows 36 and 43 are partly lit.
    assert not seen[37:43, 78].any()
    assert seen[18:36, 78].all() and seen[44:62, 78].all()
    # The pillar's face towards the camera is seen: a 2 x 2 block has no main axis, so it
    # counts from any direction.
    assert seen[39, 50] and seen[40, 50]


def test_unknown_cells_stop_rays():
    occ = square_room()
    occ[2:78, 60] = UNKNOWN             # a strip the lidar has not seen, x = 3.0 m
    seen = coverage(occ, (2.0, 2.0, 0.0))
    assert not seen.any()               # the east wall behind it is not certified
    occ[30:50, 60] = FREE               # a gap in the strip: y 1.5 .. 2.5 m
    seen = cells(coverage(occ, (2.0, 2.0, 0.0)))
    # Through the gap (|y - 2| <= 0.5 at x = 3.0, i.e. <= 0.95 at x = 3.9): rows 21 .. 58 at
    # most, and the centre certainly.
    assert {c for r, c in seen} == {78} and (40, 78) in seen
    assert min(r for r, c in seen) >= 21 and max(r for r, c in seen) <= 58


def test_a_lone_cell_counts_from_any_direction_a_wall_does_not():
    occ = np.full((40, 40), FREE, np.int8)
    occ[20, 30] = WALL                                    # alone
    occ[5:15, 30] = WALL                                  # a wall along y, rows 5..14
    # Max incidence 0: only an exactly perpendicular ray would count on the wall. From
    # (0.5, 1.025) m, cell (20, 10), the lone cell is dead ahead (0 deg) and the wall's face
    # (x = 1.5 m, y 0.25 .. 0.75 m) 15 .. 38 deg to the right, all inside -50 .. +10 deg.
    seen = cells(coverage(occ, (0.5, 1.025, -20 * DEG), hfov_deg=60.0, max_incidence_deg=0.0))
    assert seen == {(20, 30)}


def test_rays_sets_the_number_of_rays_and_zero_closes_the_gaps():
    occ = square_room()
    assert len(cells(coverage(occ, (2.0, 2.0, 0.0), rays=3))) == 3     # centre and both edges
    one = cells(coverage(occ, (2.0, 2.0, 0.0), rays=1))
    assert one == {(40, 78)}                                            # along yaw: y = 2.0
    # Automatic: at most half a cell between rays at 4 m, so every face cell in the fov.
    assert len(cells(coverage(occ, (2.0, 2.0, 0.0), rays=0))) == 44


def test_seen_accumulates_in_place():
    occ = square_room()
    acc = np.zeros(occ.shape, np.uint8)
    out = coverage(occ, (2.0, 2.0, 0.0), seen=acc)
    assert out is acc and acc.sum() == 44
    coverage(occ, (2.0, 2.0, math.pi), seen=acc)                        # now facing west
    assert acc[:, 78].sum() == 44 and acc[:, 1].sum() == 44 and acc.sum() == 88
    acc[0, 0] = 7                                                       # other cells kept
    coverage(occ, (2.0, 2.0, 0.0), seen=acc)
    assert acc[0, 0] == 7


def test_camera_off_the_grid_or_inside_a_wall():
    occ = square_room()
    assert not coverage(occ, (-1.0, 2.0, 0.0)).any()                    # off the grid
    # At the centre of a west wall cell, (40, 1): its own cell neither stops the rays nor is
    # seen; every ray (|a| <= 30 deg) leaves it eastwards into free col 2 and goes on to the
    # east wall.
    inside = cells(coverage(occ, (0.075, 2.025, 0.0)))
    assert inside and {c for r, c in inside} == {78} and (40, 1) not in inside


def test_bad_arguments_raise_value_error_naming_them():
    occ = square_room()
    good = dict(occupancy=occ, resolution=RES, origin=(0.0, 0.0), pose=(2.0, 2.0, 0.0),
                hfov_rad=1.0, max_range_m=4.0, max_incidence_rad=1.0)
    bad = [
        ("occupancy", dict(occupancy=np.zeros(5, np.int8))),
        ("resolution", dict(resolution=0.0)),
        ("resolution", dict(resolution=math.nan)),
        ("origin", dict(origin=(0.0, 0.0, 0.0))),
        ("origin", dict(origin=(math.inf, 0.0))),
        ("pose", dict(pose=(2.0, 2.0))),
        ("pose", dict(pose=(2.0, math.nan, 0.0))),
        ("pose", dict(pose="abc")),
        ("hfov_rad", dict(hfov_rad=0.0)),
        ("hfov_rad", dict(hfov_rad=3.2)),
        ("max_range_m", dict(max_range_m=0.0)),
        ("max_range_m", dict(max_range_m=math.inf)),
        ("max_incidence_rad", dict(max_incidence_rad=-0.1)),
        ("max_incidence_rad", dict(max_incidence_rad=1.6)),
        ("occupied_threshold", dict(occupied_threshold=0)),
        ("rays", dict(rays=-1)),
        ("seen", dict(seen=np.zeros(occ.shape, np.int32))),
        ("seen", dict(seen=np.zeros((3, 3), np.uint8))),
        ("seen", dict(seen=np.zeros((80, 160), np.uint8)[:, ::2])),     # not contiguous
        ("seen", dict(seen=[[0] * 80] * 80)),
    ]
    for name, change in bad:
        with pytest.raises(ValueError, match=name):
            camera_coverage(**{**good, **change})
    assert camera_coverage(**good).any()                        # the good call works
    assert camera_coverage(**{**good, "hfov_rad": math.pi}).any()


# ----------------------------------------------------------- against a Python reference

def reference_coverage(occ, pose, hfov, max_range_m, max_incidence, threshold, rays):
    """The rules of camera_coverage.hpp written out plainly, one ray and one cell at a time."""
    rows, cols = occ.shape
    seen = np.zeros(occ.shape, np.uint8)
    x0, y0 = pose[0] / RES, pose[1] / RES
    if not (0 <= x0 < cols and 0 <= y0 < rows):
        return seen
    far = math.hypot(max(x0, cols - x0), max(y0, rows - y0))
    reach = min(max_range_m / RES, far + 1.0)

    def wall_tangent(r, c):
        # Covariance of the occupied offsets in the 5 x 5 window, as sums / n - mean^2.
        d = [(dx, dy) for dy in range(-2, 3) for dx in range(-2, 3)
             if 0 <= r + dy < rows and 0 <= c + dx < cols and occ[r + dy, c + dx] >= threshold]
        n = len(d)
        mx, my = sum(x for x, _ in d) / n, sum(y for _, y in d) / n
        a = sum(x * x for x, _ in d) / n - mx * mx
        c_ = sum(y * y for _, y in d) / n - my * my
        b = sum(x * y for x, y in d) / n - mx * my
        mean, radius = 0.5 * (a + c_), math.hypot(0.5 * (a - c_), b)
        if not (mean + radius > 0) or mean + radius < 2.0 * (mean - radius):
            return None             # no main axis: seen from any direction
        return 0.5 * math.atan2(2 * b, a - c_)

    for k in range(rays):
        angle = pose[2] if rays == 1 else pose[2] - hfov / 2 + hfov * k / (rays - 1)
        x1, y1 = x0 + reach * math.cos(angle), y0 + reach * math.sin(angle)
        for i, (r, c) in enumerate(grid_traversal(x0, y0, x1, y1)):
            if not (0 <= r < rows and 0 <= c < cols):
                break
            if i == 0:
                continue
            if occ[r, c] < 0:
                break
            if occ[r, c] >= threshold:
                tangent = wall_tangent(r, c)
                if tangent is None or abs(math.sin(angle - tangent)) >= math.cos(max_incidence):
                    seen[r, c] = 1
                break
    return seen


@pytest.mark.parametrize("seed", range(6))
def test_matches_the_python_reference_on_random_maps(seed):
    rng = np.random.default_rng(seed)
    occ = np.full((60, 70), FREE, np.int8)
    occ[rng.random(occ.shape) < 0.03] = WALL                    # scattered cells
    for _ in range(6):                                          # wall segments, some diagonal
        r, c = rng.integers(0, 60), rng.integers(0, 70)
        dr, dc = rng.integers(-1, 2), rng.integers(-1, 2)
        for t in range(int(rng.integers(5, 25))):
            if 0 <= r + t * dr < 60 and 0 <= c + t * dc < 70:
                occ[r + t * dr, c + t * dc] = WALL
    occ[rng.random(occ.shape) < 0.02] = UNKNOWN
    occ[rng.random(occ.shape) < 0.02] = 50                      # undecided: lets rays through
    free = np.argwhere(occ == FREE)
    for trial in range(5):
        r, c = free[rng.integers(len(free))]
        pose = ((c + rng.random()) * RES, (r + rng.random()) * RES, rng.uniform(-math.pi, math.pi))
        hfov, max_range = rng.uniform(0.3, math.pi), rng.uniform(0.5, 4.0)
        max_incidence, rays = rng.uniform(0.2, math.pi / 2), int(rng.integers(1, 120))
        got = camera_coverage(occ, RES, (0.0, 0.0), pose, hfov, max_range, max_incidence,
                                      rays=rays)
        want = reference_coverage(occ, pose, hfov, max_range, max_incidence, 65, rays)
        assert np.array_equal(got, want), (seed, trial)


# ------------------------------------------------------------------------- CameraCoverage

def make_coverage(**settings):
    settings.setdefault("tag_size_m", 0.16)        # the tests' geometry was laid out for 4.2 m
    return CameraCoverage(fx_px=530.0, hfov_rad=60 * DEG, settings=CoverageSettings(**settings))


def test_max_range_is_where_a_tag_shrinks_to_min_tag_px():
    cov = CameraCoverage.for_camera(CameraSpec())               # waffle_pi: 640 px, 62.2 deg
    # fx = 320 / tan 31.1 deg = 530.5 px; the default 0.10 m * 530.5 px / 20 px = 2.652 m.
    assert cov.max_range_m == pytest.approx(2.652, abs=1e-3)
    assert make_coverage(min_tag_px=40.0).max_range_m == pytest.approx(0.16 * 530 / 40)


def test_settings_and_constructor_validate():
    for key, value in [("max_incidence_rad", 2.0), ("max_incidence_rad", -0.1),
                       ("min_tag_px", 0.0), ("tag_size_m", -0.16), ("tag_size_m", math.nan),
                       ("rays", -1)]:
        with pytest.raises(ValueError, match=key):
            CoverageSettings(**{key: value})
    with pytest.raises(ValueError, match="fx_px"):
        CameraCoverage(fx_px=0.0, hfov_rad=1.0)
    with pytest.raises(ValueError, match="hfov_rad"):
        CameraCoverage(fx_px=530.0, hfov_rad=4.0)
    cov = make_coverage()
    with pytest.raises(ValueError, match="occupancy"):
        cov.update(square_room().astype(np.int16), RES, (0, 0), (2, 2, 0))
    with pytest.raises(ValueError, match="resolution"):
        cov.update(square_room(), 0.0, (0, 0), (2, 2, 0))
    with pytest.raises(ValueError, match="pose"):
        cov.update(square_room(), RES, (0, 0), (2, 2))
    with pytest.raises(ValueError, match="reachable_free_mask"):
        cov.wall_cells(square_room(), np.zeros((3, 3), bool))


def test_seen_share_from_zero_to_one():
    occ = square_room()
    reachable = occ == FREE
    cov = make_coverage()
    # Wall faces: the 76 cells along each side of the 76 x 76 free square = 304. The inner
    # corner cells (diagonal to the free square only) are not wall faces: no ray hits them
    # first, so they would hold the share below 1 for ever.
    walls = cov.wall_cells(occ, reachable)
    assert walls.sum() == 304 and not walls[1, 1] and walls[2, 1] and walls[1, 2]
    assert cov.seen_share(occ, reachable) == 0.0                # nothing seen yet
    cov.update(occ, RES, (0.0, 0.0), (2.0, 2.0, 0.0))
    assert cov.seen_share(occ, reachable) == pytest.approx(44 / 304)
    for yaw in np.arange(1, 8) * 45 * DEG:                      # turn on the spot
        cov.update(occ, RES, (0.0, 0.0), (2.0, 2.0, yaw))
    assert cov.seen_share(occ, reachable) == 1.0
    no_walls = np.full(occ.shape, FREE, np.int8)
    assert cov.seen_share(no_walls, no_walls == FREE) == 1.0    # no wall: nothing to see


def test_mask_survives_the_grid_growing():
    occ = square_room()
    cov = make_coverage()
    cov.update(occ, RES, (0.0, 0.0), (2.0, 2.0, 0.0))
    before = cov.seen.copy()
    assert cov.seen[40, 78]                 # the wall cell around (3.925, 2.025) m
    # The mapper grows its grid by 10 cells west, 6 south, 4 east: origin (-0.5, -0.3) m,
    # old cell (r, c) is new cell (r + 6, c + 10). Facing away (west) adds the west wall.
    grown = np.full((86, 94), UNKNOWN, np.int8)
    grown[6:86, 10:90] = occ
    cov.update(grown, RES, (-0.5, -0.3), (2.0, 2.0, math.pi))
    assert cov.seen.shape == grown.shape
    # (3.925, 2.025) m is now cell (floor(2.325 / 0.05), floor(4.425 / 0.05)) = (46, 88).
    assert cov.seen[46, 88]
    assert np.array_equal(cov.seen[6:86, 10:90][:, 40:], before[:, 40:])   # east half kept
    assert cov.seen[6:86, 10 + 1].sum() == 44 and cov.seen.sum() == 88
    # The grid's window moves east (the west part cropped): the east wall is still marked.
    cropped = grown[:, 40:]
    cov.update(cropped, RES, (-0.5 + 40 * RES, -0.3), (2.0, 2.0, math.pi / 2))
    assert cov.seen[6:86, 10 + 78 - 40].sum() == 44 and cov.seen.shape == cropped.shape


def test_resolution_change_or_sub_cell_shift_resets_with_a_warning(caplog):
    occ = square_room()
    cov = make_coverage()
    cov.update(occ, RES, (0.0, 0.0), (2.0, 2.0, 0.0))
    with caplog.at_level(logging.WARNING, logger="turtlebot_recon.perception.camera_coverage"):
        cov.update(occ, RES, (0.02, 0.0), (2.0, 2.0, math.pi))      # 0.4 cell: edges differ
    assert "fraction of a cell" in caplog.text
    assert cov.seen[:, 78].sum() == 0 and cov.seen.sum() > 0        # the east wall forgotten
    caplog.clear()
    coarse = occ[::2, ::2].copy()
    with caplog.at_level(logging.WARNING, logger="turtlebot_recon.perception.camera_coverage"):
        cov.update(coarse, 2 * RES, (0.0, 0.0), (2.0, 2.0, 0.0))
    assert "resolution changed" in caplog.text
    assert cov.seen[:, :20].sum() == 0                              # the west wall forgotten


def test_occupancy_grid_data_marks_seen_and_unseen_walls():
    occ = square_room()
    cov = make_coverage()
    with pytest.raises(ValueError, match="update"):
        cov.to_occupancy_grid_data()
    cov.update(occ, RES, (0.0, 0.0), (2.0, 2.0, 0.0))
    data = cov.to_occupancy_grid_data()
    assert data.dtype == np.int8 and data.shape == occ.shape
    assert (data == WALL_SEEN).sum() == 44 and data[40, 78] == WALL_SEEN
    assert (data == WALL_UNSEEN).sum() == (occ == WALL).sum() - 44       # all other walls
    assert (data[occ == FREE] == 0).all()
    faces = cov.to_occupancy_grid_data(reachable_free_mask=occ == FREE)
    assert (faces == WALL_UNSEEN).sum() == 304 - 44 and faces[0, 0] == 0  # outer cells: 0
