"""The compiled module: rectangle merging (world loading) and the linked C++ libraries."""
import numpy as np

from turtlebot_recon import _native


def paint(rects, shape):
    out = np.zeros(shape, np.int32)
    for r, c, h, w in rects:
        out[r:r + h, c:c + w] += 1
    return out


def test_rectangles_cover_mask_exactly_and_disjointly():
    rng = np.random.default_rng(0)
    for trial in range(50):
        shape = tuple(rng.integers(1, 40, 2))
        mask = rng.random(shape) < rng.uniform(0.1, 0.9)
        rects = _native.merge_rectangles(mask.astype(np.uint8))
        count = paint(rects, shape)
        # every solid cell covered exactly once, no free cell covered
        assert np.array_equal(count, mask.astype(np.int32)), trial


def test_solid_blocks_merge_into_few_rectangles():
    mask = np.zeros((100, 200), np.uint8)
    mask[:5, :] = 1          # top wall: one rectangle
    mask[10:60, 20:30] = 1   # a block: one rectangle
    rects = _native.merge_rectangles(mask)
    assert len(rects) == 2
    assert sorted(map(tuple, rects.tolist())) == [(0, 0, 5, 200), (10, 20, 50, 10)]


def test_empty_and_full():
    assert _native.merge_rectangles(np.zeros((0, 0), np.uint8)).shape == (0, 4)
    assert _native.merge_rectangles(np.ones((7, 9), np.uint8)).tolist() == [[0, 0, 7, 9]]


def test_libraries_linked():
    info = _native.build_info()
    assert info["eigen"].startswith("3.")
    assert info["octomap"] == "OcTree"
    assert info["ompl"].count(".") == 2
