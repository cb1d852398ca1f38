"""/map on the wire: the mapper's numpy OccupancyGrid is the standard message for any
subscriber (rviz, map_saver), and ``explore_msgs.grid`` reads both kinds back (no master)."""
from io import BytesIO

import numpy as np
from nav_msgs.msg import OccupancyGrid

from turtlebot_recon.ros import convert, explore_msgs


def wire(m) -> bytes:
    buff = BytesIO()
    m.serialize(buff)
    return buff.getvalue()


def test_numpy_grid_round_trips_for_plain_and_numpy_subscribers():
    rng = np.random.default_rng(3)
    values = rng.choice(np.array([-1, 0, 50, 100], dtype=np.int8), size=(7, 5))
    sent = convert.occupancy_grid(values, 0.05, (-1.5, 2.0), "map", 12.5)
    raw = wire(sent)

    plain = OccupancyGrid()
    plain.deserialize(raw)                            # what rviz / map_saver would get
    assert (plain.info.height, plain.info.width) == (7, 5)
    assert list(plain.data) == values.ravel().tolist()
    assert raw == wire(plain)                         # same bytes as the plain message

    fast = convert.OccupancyGridNumpy()
    fast.deserialize(raw)
    assert isinstance(fast.data, np.ndarray)
    for m in (plain, fast):
        occ, res, origin = explore_msgs.grid(m)
        np.testing.assert_array_equal(occ, values)
        assert res == np.float32(0.05) and origin == (-1.5, 2.0)   # resolution is float32
        occ[0, 0] = 7                                 # a writable copy, not the message buffer
        assert m.data[0] == values[0, 0]
