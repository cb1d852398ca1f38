"""The body against a distance field (include/turtlebot_recon/body_field.hpp): the sampling
controllers' obstacle test agrees with the exact footprint check of the planner."""
from functools import partial

import numpy as np
import pytest

from turtlebot_recon import _native
from turtlebot_recon.mapping.map_io import OCCUPIED_THRESH
from turtlebot_recon.robot import footprint_args as body, load_robot

RES = 0.05
ROBOTS = ["turtlebot3_waffle_pi", "turtlebot3_burger", "turtlebot2"]
# the bindings take every argument: a round body, a 5 cm outline spacing, a 1 m cap and
# map_server's occupied threshold unless a test gives its own
ROUND = dict(footprint_length_m=0.0, footprint_width_m=0.0, footprint_offset_x_m=0.0)
body_field_clearance = partial(_native.body_field_clearance, **ROUND, spacing_m=0.05, max_m=1.0,
                               occupied_threshold=OCCUPIED_THRESH)
footprint_clearance = partial(_native.footprint_clearance, **ROUND, occupied_threshold=OCCUPIED_THRESH)


def random_map(rng, rows=60, cols=60, blobs=25):
    occ = np.zeros((rows, cols), np.int8)
    for _ in range(blobs):
        r, c = rng.integers(0, rows), rng.integers(0, cols)
        occ[r:r + rng.integers(1, 4), c:c + rng.integers(1, 4)] = 100
    occ[rng.random((rows, cols)) < 0.05] = -1            # unknown cells are no obstacles
    return occ


def corridor(width_m, rows=40, cols=80):
    """A corridor along +x of the given free width (metres, a multiple of RES), centred on y = 1 m."""
    occ = np.full((rows, cols), 100, np.int8)
    half = int(round(width_m / RES / 2))
    occ[20 - half:20 + half, :] = 0
    return occ


@pytest.mark.parametrize("width_m, fits", [(0.40, True), (0.30, False)])
def test_the_waffle_box_fits_a_corridor_its_turning_disc_does_not(width_m, fits):
    """The waffle_pi (0.306 m wide) down the middle of a 0.40 m corridor keeps ~4.7 cm either
    side; a 0.30 m one overlaps its walls. Its turning disc (0.257 m) fits neither."""
    robot = load_robot("turtlebot3_waffle_pi")
    occ = corridor(width_m)
    poses = [[x, 1.0, 0.0] for x in np.linspace(1.0, 3.0, 9)]
    d = body_field_clearance(occ, RES, (0.0, 0.0), poses, **body(robot), max_m=0.3)
    if fits:
        assert d == pytest.approx(np.full(len(poses), (0.40 - robot.footprint_width_m) / 2), abs=0.01)
    else:
        assert (d < 0).all()
    disc = body_field_clearance(occ, RES, (0.0, 0.0), poses, radius_m=robot.radius_m, max_m=0.3)
    assert (disc < 0).all()


@pytest.mark.parametrize("name", ROBOTS)
def test_clearance_brackets_the_exact_footprint_check(name):
    """Within the field's cell error (and the outline's spacing / 2) of the exact check."""
    robot = load_robot(name)
    rng = np.random.default_rng(3)
    occ = random_map(rng)
    poses = np.column_stack([rng.uniform(0.5, 2.5, 400), rng.uniform(0.5, 2.5, 400),
                             rng.uniform(-np.pi, np.pi, 400)])
    exact = footprint_clearance(occ, RES, (0.0, 0.0), poses, **body(robot), max_m=0.3,
                                        unknown_is_obstacle=False)
    approx = body_field_clearance(occ, RES, (0.0, 0.0), poses, **body(robot), max_m=0.3)
    free = (exact > 0) & (exact < 0.3)                   # apart, below the exact check's cap
    err = RES * 0.75                                     # centre-to-centre field vs the edge
    assert (approx[free] <= exact[free] + err + 0.025).all()
    assert (approx[free] >= exact[free] - err).all()
    assert (approx[exact <= 0] <= err + 0.025).all()     # touching: near or below zero
    assert np.abs(approx[free] - exact[free]).mean() < 0.015
    far = exact >= 0.3
    assert (approx[far] >= 0.3 - err).all()


def test_empty_grid_is_far_and_bad_arguments_say_what():
    occ = np.zeros((10, 10), np.int8)
    d = body_field_clearance(occ, RES, (0.0, 0.0), [[0.2, 0.2, 0.0]], radius_m=0.1)
    assert d[0] == 1.0                                   # max_m: nothing nearer
    with pytest.raises(ValueError, match="body_field_clearance: poses"):
        body_field_clearance(occ, RES, (0.0, 0.0), [[0.2, 0.2]], radius_m=0.1)
    with pytest.raises(ValueError, match="radius_m"):
        body_field_clearance(occ, RES, (0.0, 0.0), [[0.2, 0.2, 0.0]], radius_m=-1.0)
