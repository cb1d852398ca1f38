"""The shipped worlds: load, sizes and tag counts as promised, start valid, regenerable."""
import math

import numpy as np
import pytest
from scipy import ndimage

from turtlebot_recon.sim import load_world, worldgen

SPEC = {  # name: (min width m, min height m, min tags)
    "house": (14.5, 9.5, 6),        # a 15 x 10 m building, walls included
    "maze": (7.0, 7.0, 3),
    "office": (30.0, 20.0, 8),
    "arena": (15.0, 15.0, 4),
    "garden": (11.5, 9.5, 4),       # held-out worlds (bench-explore's HELD_OUT): 12 x 10 m
    "doors": (15.5, 10.5, 8),       # 16 x 11 m
}
BURGER_BAND_M = 0.105 + 0.05 * math.sqrt(2)    # the planner's inscribed band for the burger, 0.176 m


@pytest.mark.parametrize("name", sorted(SPEC))
def test_shipped_world(name):
    w = load_world(name)
    min_w, min_h, min_tags = SPEC[name]
    free_rows, free_cols = np.nonzero(w.free)
    extent = ((np.ptp(free_cols) + 1) * w.resolution, (np.ptp(free_rows) + 1) * w.resolution)
    assert extent[0] >= min_w - 0.3 and extent[1] >= min_h - 0.3
    assert len(w.tags) >= min_tags
    # every tag faces free space and is reachable: the cell 0.3 m in front is in the start's region
    reach, _ = ndimage.label(w.clearance() >= 0.15)
    start_label = reach[w.cell(*w.start[:2])]
    assert start_label > 0
    for t in w.tags:
        r, c = w.cell(t.x + 0.3 * math.cos(t.yaw), t.y + 0.3 * math.sin(t.yaw))
        assert reach[r, c] == start_label, (name, t.id)


@pytest.mark.parametrize("name", ["garden", "doors"])
def test_held_out_worlds_need_the_narrow_passages(name):
    # Every room is in reach of the burger's planner band (0.176 m: a 0.45 m door leaves
    # 0.45 - 2 * 0.176 = 0.10 m for the centre), and a robot needing over 0.45 m (a centre
    # clearance of 0.23 m: a door's middle pixel has 0.225 m) is shut out of whole rooms or rock fields.
    image, meta = getattr(worldgen, name)()
    assert worldgen.validate_world(image, meta, radius=BURGER_BAND_M) == []
    shut_out = worldgen.validate_world(image, meta, radius=0.23)
    assert any(p.startswith("unreachable free area") for p in shut_out), shut_out


@pytest.mark.parametrize("name", ["maze", "house", "garden", "doors"])
def test_worlds_are_regenerated_identically(tmp_path, name):
    image, meta = getattr(worldgen, name)()
    worldgen.write_world(tmp_path, name, image, meta)
    from turtlebot_recon.sim.world import WORLDS_DIR
    assert (tmp_path / f"{name}.pgm").read_bytes() == (WORLDS_DIR / f"{name}.pgm").read_bytes()
    assert (tmp_path / f"{name}.yaml").read_text() == (WORLDS_DIR / f"{name}.yaml").read_text()
