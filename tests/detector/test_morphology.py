"""Morphology (paper eq. 31): hole filling against scipy, the ego's component."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from simroad import SimroadError
from simroad.detector import extend_upward, fill_holes, keep_ego_component, postprocess


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("density", [0.3, 0.5, 0.7])
def test_fill_holes_equals_scipy(seed, density):
    rng = np.random.default_rng(seed)
    mask = ndimage.binary_opening(rng.random((40, 57)) < density)
    np.testing.assert_array_equal(fill_holes(mask), ndimage.binary_fill_holes(mask))


def test_fill_holes_eq31_iteration_by_hand():
    a = np.array(
        [[0, 0, 0, 0, 0],
         [0, 1, 1, 1, 0],
         [0, 1, 0, 1, 0],
         [0, 1, 1, 1, 0],
         [0, 0, 0, 0, 0]], bool)  # fmt: skip
    expect = a.copy()
    expect[2, 2] = True  # X_0 = centre; X_1 = dilate(X_0) & ~A = centre: converged, the hole
    np.testing.assert_array_equal(fill_holes(a), expect)
    a[2, 0] = False
    a[2, 1] = False  # open the ring to the border: no hole any more (4-connected background)
    np.testing.assert_array_equal(fill_holes(a), a)


def test_keep_ego_component_prefers_bottom_centre_then_largest():
    mask = np.zeros((40, 60), bool)
    mask[30:40, 25:35] = True  # under the ego, small
    mask[0:20, 0:60] = True  # large, elsewhere
    np.testing.assert_array_equal(keep_ego_component(mask), np.pad(np.ones((10, 10), bool), ((30, 0), (25, 25))))
    mask[30:40, 25:35] = False  # nothing under the ego: the largest component
    np.testing.assert_array_equal(keep_ego_component(mask), mask)
    assert not keep_ego_component(np.zeros((5, 5), bool)).any()


def test_postprocess_is_ego_component_with_holes_filled():
    mask = np.zeros((30, 30), bool)
    mask[10:30, 5:25] = True
    mask[15:18, 12:15] = False  # a hole (e.g. a lane marking called non-road)
    mask[0:5, 0:5] = True  # a far-away speck
    out = postprocess(mask)
    expect = np.zeros_like(mask)
    expect[10:30, 5:25] = True
    np.testing.assert_array_equal(out, expect)


def test_morphology_rejects_bad_masks():
    with pytest.raises(SimroadError, match="mask: expected a bool"):
        fill_holes(np.zeros((4, 4), np.float32))
    with pytest.raises(SimroadError, match="mask: expected a 2-D"):
        keep_ego_component(np.zeros((4, 4, 1), bool))


def test_extend_upward_keeps_the_far_road_and_drops_a_verge_joined_only_above_by_hand():
    road = np.zeros((6, 8), bool)
    road[2:, 1:3] = True  # the road near the car: columns 1-2
    road[0:2, 1:7] = True  # far rows: the road, and the verge joined to it
    road[3:, 5:7] = True  # the verge near the car, apart from the road
    seed = np.zeros_like(road)
    seed[4:, 1:3] = True  # the road found without the filter
    want = np.zeros_like(road)
    want[2:, 1:3] = True  # the road, up from the seed
    want[0:2, 1:7] = True  # the far rows, reached from the row below
    assert np.array_equal(extend_upward(road, seed), want)
    # a run touching the kept run below only diagonally is kept (8-connected)
    diag = np.zeros((2, 4), bool)
    diag[1, 0] = diag[0, 1] = True
    bottom = np.zeros_like(diag)
    bottom[1, 0] = True
    assert np.array_equal(extend_upward(diag, bottom), diag)
    assert not extend_upward(diag, ~bottom & diag)[1, 0]  # never down


def test_extend_upward_is_a_subset_of_the_road_holding_every_seeded_run():
    rng = np.random.default_rng(3)
    for _ in range(20):
        road = rng.random((30, 40)) < 0.6
        seed = road & (rng.random((30, 40)) < 0.05)
        out = extend_upward(road, seed)
        assert not (out & ~road).any() and not (seed & ~out).any()
        # every kept pixel is reached: its run holds a seed or touches a kept pixel below
        assert np.array_equal(extend_upward(road, out), out)


def test_extend_upward_refuses_masks_of_other_shapes_by_name():
    with pytest.raises(SimroadError, match="seed"):
        extend_upward(np.ones((4, 4), bool), np.ones((4, 5), bool))
