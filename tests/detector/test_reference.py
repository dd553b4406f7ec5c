"""Colours referenced to the road ahead, and lane markings kept apart (simroad.detector.reference)."""

from __future__ import annotations

import numpy as np
import pytest

from simroad import SimroadError
from simroad.detector import RoadDetector
from simroad.detector.morphology import _ego_component, _ego_component_apart
from simroad.detector.reference import (
    ROAD_AHEAD_LEVEL,
    marking_mask,
    normalize_planes,
    normalize_rows,
    road_ahead_gains,
)

H, W = 90, 160


def _planes(rgb: tuple[int, int, int]) -> list[np.ndarray]:
    return [np.full((H, W), v, np.uint8) for v in rgb]


def test_the_gains_bring_the_patch_median_to_the_reference_grey():
    planes = _planes((50, 60, 80))
    # by hand: gain_c = (100 / 255) / (level_c / 255) = 100 / level_c
    np.testing.assert_allclose(road_ahead_gains(planes), [100 / 50, 100 / 60, 100 / 80])
    out = normalize_planes(planes, "road_ahead")
    assert all(p.dtype == np.float32 for p in out)
    np.testing.assert_allclose([float(p[0, 0]) for p in out], [ROAD_AHEAD_LEVEL / 255] * 3, rtol=1e-6)


def test_only_the_patch_ahead_sets_the_gains_and_its_median_ignores_a_minority():
    planes = _planes((40, 40, 40))
    planes[0][: H // 2] = 250  # sky and verges do not count
    planes[1][int(0.85 * H) :, W // 2 - 2 : W // 2 + 2] = 255  # a lane marking inside the patch
    np.testing.assert_allclose(road_ahead_gains(planes), [100 / 40] * 3)


def test_float_planes_and_rows_give_the_same_gains_as_uint8():
    rng = np.random.default_rng(0)
    img = rng.integers(20, 200, (H, W, 3), dtype=np.uint8)
    g8 = road_ahead_gains([img[..., c] for c in range(3)])
    gf = road_ahead_gains([img[..., c].astype(np.float32) / 255 for c in range(3)])
    np.testing.assert_allclose(g8, gf, rtol=1e-6)
    rows = normalize_rows(img.reshape(-1, 3) / 255.0, (H, W), "road_ahead")
    planes = normalize_planes([img[..., c] for c in range(3)], "road_ahead")
    np.testing.assert_allclose(rows, np.stack([p.ravel() for p in planes], axis=1), atol=1e-6)
    assert normalize_rows(rows, (H, W), "none") is rows


def test_a_black_patch_keeps_finite_gains_and_excluded_pixels_are_left_out():
    assert np.all(np.isfinite(road_ahead_gains(_planes((0, 0, 0)))))
    planes = _planes((40, 40, 40))
    lobe = np.zeros((H, W), bool)
    planes[0][int(0.8 * H) :, : W // 2 + 2] = 200  # a sun's reflection over half the patch...
    lobe[int(0.8 * H) :, : W // 2 + 2] = True
    assert road_ahead_gains(planes)[0] < 100 / 40
    np.testing.assert_allclose(road_ahead_gains(planes, lobe), [100 / 40] * 3)  # ... left out
    lobe[:] = True  # a reflection over the whole patch: the whole patch still counts
    np.testing.assert_allclose(road_ahead_gains(planes, lobe), road_ahead_gains(planes))


def test_markings_are_thin_bright_lines_at_any_width():
    for w in (160, 320, 640):
        planes = [np.full((H, w), 80, np.uint8) for _ in range(3)]
        x = w // 2
        line = max(1, w // 160)
        for p in planes:
            p[:, x : x + line] = 230  # paint
            p[:, : w // 4] = 200  # a wide pale verge: not a marking
        marks = marking_mask(planes)
        assert marks[:, x : x + line].all()
        assert not marks[:, : w // 4 - 8].any() and not marks[:, x + line + 8 :].any()


def test_a_marking_no_longer_bridges_the_road_to_a_pale_verge():
    road = np.zeros((H, W), bool)
    road[H // 2 :, W // 4 : 3 * W // 4] = True  # the ego's road
    verge = np.zeros((H, W), bool)
    verge[H // 2 :, 3 * W // 4 + 3 :] = True  # a verge the classifier calls road ...
    line = np.zeros((H, W), bool)
    line[H // 2 :, 3 * W // 4 : 3 * W // 4 + 3] = True  # ... joined by the edge line
    mask = road | verge | line
    assert _ego_component(mask).sum() == mask.sum()  # one component: the verge comes along
    apart = _ego_component_apart(mask, line)
    np.testing.assert_array_equal(apart, road | line)  # the line is road, the verge is not
    stray = np.zeros((H, W), bool)
    stray[5:10, 5:8] = True  # a marking that touches nothing is left out
    np.testing.assert_array_equal(_ego_component_apart(mask | stray, line | stray), road | line)


def test_normalize_is_validated_by_name():
    rng = np.random.default_rng(1)
    images = [rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)]
    masks = [np.arange(24 * 32).reshape(24, 32) % 2 == 0]
    with pytest.raises(SimroadError, match="normalize"):
        RoadDetector(normalize="road").fit(images, masks)
