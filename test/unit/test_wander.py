"""The scripted wander's core (sim/wander.py): scan sectors and the steering rule."""
import math

import numpy as np
import pytest

from turtlebot_recon.sim.wander import WanderSettings, command, sectors


def test_sectors_take_the_nearest_valid_return_of_each():
    # 8 beams every 45 deg from -180: bearings -180, -135, -90, -45, 0, 45, 90, 135 (deg).
    # front [-34, 34] deg holds 0 deg; left [17, 74] deg holds 45; right [-74, -17] holds -45.
    r = np.array([0.3, 0.3, 0.3, 2.0, 1.5, 0.8, 0.3, 0.3])
    assert sectors(r, -math.pi, math.pi / 4, 0.12, 3.5) == (1.5, 0.8, 2.0)
    # no valid return (0.0 from the LDS-01, inf, NaN, under range_min) reads as range_max
    r = np.array([0.3, 0.3, 0.3, np.nan, 0.0, np.inf, 0.3, 0.3])
    assert sectors(r, -math.pi, math.pi / 4, 0.12, 3.5) == (3.5, 3.5, 3.5)
    # a scan over [0, 2 pi): 315 deg is -45 after wrapping, in the right sector
    r = np.full(8, 3.0)
    r[7] = 0.9
    assert sectors(r, 0.0, math.pi / 4, 0.12, 3.5)[2] == 0.9


def test_command_turns_in_place_when_blocked_and_steers_to_the_open_side():
    s = WanderSettings()
    # front 0.4 < clearance 0.55: turn in place the way it last turned (right, -1)
    assert command(0.4, 3.0, 0.5, -1.0, s) == (0.0, -1.0, -1.0)
    # open ahead (1.0 m): speed 0.2 * (1.0 - 0.2) / 0.8 = 0.2; left more open by 1 m:
    # angular 0.6 * 1.0 * tanh(1.0) = 0.4570; next turn in place to the left
    v, w, turn = command(1.0, 2.0, 1.0, -1.0, s)
    assert v == pytest.approx(0.2) and w == pytest.approx(0.6 * math.tanh(1.0)) and turn == 1.0
    # at 0.6 m ahead it slows: 0.2 * 0.4 / 0.8 = 0.1 m/s
    assert command(0.6, 1.0, 1.0, 1.0, s)[0] == pytest.approx(0.1)


def test_settings_are_checked():
    from turtlebot_recon.config import ConfigError, from_dict
    with pytest.raises(ConfigError, match="src/duration_s"):
        from_dict(WanderSettings, {"duration_s": -1.0}, "src")
    with pytest.raises(ConfigError, match="src/clearance_m"):
        from_dict(WanderSettings, {"clearance_m": 0.0}, "src")
