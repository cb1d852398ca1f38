"""The tag search: views of the walls the camera has not seen and of unconfirmed tags."""
import math

import numpy as np
import pytest

from turtlebot_recon.exploration.context import Context
from turtlebot_recon.exploration.tag_search import (TagSearch, TagSearchSettings, View,
                                                    best_window)
from turtlebot_recon.perception.tracker import Glimpse
from turtlebot_recon.planning import dijkstra
from turtlebot_recon.robot import load_robot

RES = 0.05


def room(w_cells=120, h_cells=80):
    """A walled 6 x 4 m room (origin (0, 0)); free inside, walls one cell thick."""
    occ = np.zeros((h_cells, w_cells), np.int8)
    occ[0, :] = occ[-1, :] = 100
    occ[:, 0] = occ[:, -1] = 100
    return occ


def context(occ, robot_xy=(1.0, 2.0)):
    costmap = np.where(occ < 0, 255, np.where(occ >= 65, 254, 0)).astype(np.uint8)
    costmap[1:3, :] = costmap[-3:-1, :] = 253                 # the band next to the walls
    costmap[:, 1:3] = costmap[:, -3:-1] = 253
    cell = (int(robot_xy[1] / RES), int(robot_xy[0] / RES))
    field = dijkstra(costmap, cell, resolution=RES)
    return Context(robot_xy=robot_xy, robot_yaw=0.0, now_s=0.0, resolution=RES, origin=(0.0, 0.0),
                   occupancy=occ, costmap=costmap, cost_to_come=field, visits=None,
                   rng=np.random.default_rng(0))


def search(**kw):
    return TagSearch(TagSearchSettings(**kw), load_robot("turtlebot3_waffle_pi").camera)


def never(_xy):
    return False


def test_a_wall_view_faces_unseen_wall_and_an_all_round_look_ends_the_search():
    occ, ts = room(), search()
    ctx = context(occ)
    view = ts.choose(ctx, [], never)
    assert view is not None and view.kind == "wall" and view.gain_m >= 0.5
    assert ts.seen_share == 0.0
    # the camera at the view, facing its heading, sees wall it had not: the share grows
    ts.saw(occ, RES, (0.0, 0.0), (*view.xy, view.yaw))
    assert 0.0 < ts.unseen_walls(ctx).sum() < ts.walls.sum()
    before = ts.seen_share
    # a look round from the room's middle and from both ends shows every wall within 4.2 m
    for x in (1.5, 3.0, 4.5):
        for k in range(16):
            ts.saw(occ, RES, (0.0, 0.0), (x, 2.0, k * math.pi / 8))
    assert ts.choose(ctx, [], never) is None
    assert ts.seen_share >= 0.95 > before


def test_an_unconfirmed_tag_comes_first_and_is_looked_at_from_in_front():
    occ, ts = room(), search()
    ctx = context(occ)
    tag = Glimpse("tag36h11", 4, 5.95, 2.5, math.pi, 0.0)     # on the east wall, facing west
    view = ts.choose(ctx, [tag], never)
    assert view.kind == "tag" and view.targets == ("tag36h11", 4)
    assert math.dist(view.xy, (4.95, 2.5)) <= 0.6 + 1e-9       # tag_view_m in front (snapped)
    assert abs(math.remainder(view.yaw - math.atan2(2.5 - view.xy[1], 5.95 - view.xy[0]), 2 * math.pi)) < 1e-9
    ts.reached(view)
    ts.reached(view)                                          # looked at twice: left as it is
    assert ts.choose(ctx, [tag], never).kind == "wall"


def test_the_view_pursued_is_kept_until_its_wall_is_seen_and_a_reached_view_is_not_offered_again():
    occ, ts = room(), search()
    ctx = context(occ)
    first = ts.choose(ctx, [], never)
    other = View((4.0, 2.0), 0.0, "wall", 1.0, "", first.targets)
    assert ts.choose(ctx, [], never, pursued=other) is other   # its wall is still unseen
    for k in range(16):                                        # now it is seen
        ts.saw(occ, RES, (0.0, 0.0), (*first.xy, k * math.pi / 8))
    assert ts.choose(ctx, [], never, pursued=other) is not other
    ts2 = search()
    v = ts2.choose(ctx, [], never)
    ts2.reached(v)                                             # the camera saw nothing from there
    w = ts2.choose(ctx, [], never)
    assert w is not None and not set(w.targets) & set(v.targets)


def test_failed_views_are_skipped_and_nothing_reachable_ends_it():
    occ, ts = room(), search()
    ctx = context(occ)
    v = ts.choose(ctx, [], never)
    w = ts.choose(ctx, [], lambda xy: math.dist(xy, v.xy) < 0.2)
    assert w is not None and math.dist(w.xy, v.xy) >= 0.2
    assert ts.choose(ctx, [], lambda xy: True) is None


@pytest.mark.parametrize("bearings, half, yaw, count", [
    ([0.1, 0.2, 0.3, 2.0], 0.2, 0.2, 3),
    ([3.1, -3.1, 3.0, 0.0], 0.1, math.pi, 3),                  # across +-pi
    ([1.0], 0.5, 1.0, 1),
])
def test_best_window(bearings, half, yaw, count):
    y, n = best_window(np.array(bearings), half)
    assert n == count and abs(math.remainder(y - yaw, 2 * math.pi)) < 0.06
