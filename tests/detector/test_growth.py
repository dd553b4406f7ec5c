"""Region growing across smooth illumination (simroad.detector.growth)."""

from __future__ import annotations

import numpy as np
import pytest

from simroad import SimroadError
from simroad.detector.growth import _across_lobe, grow_road


def _scene() -> np.ndarray:
    """Grey road in columns 80..239 whose brightness rises smoothly 90 -> 150 codes
    towards its centre (a glare lobe), between green grass; sky above row 60."""
    img = np.zeros((180, 320, 3), np.uint8)
    img[:, :] = (60, 110, 40)
    col = np.arange(80, 240)
    level = 90 + 60 * np.exp(-0.5 * ((col - 160) / 50.0) ** 2)  # at most 0.8 codes per pixel
    img[60:, 80:240] = np.round(level)[None, :, None].astype(np.uint8)
    img[:60] = (150, 180, 220)
    return img


def test_grow_road_follows_a_smooth_lobe_and_stops_at_the_road_edge():
    img = _scene()
    seeds = np.zeros((180, 320), bool)
    seeds[170:, 100:120] = True  # the SVM kept only a dark strip beside the lobe
    ground = np.zeros((180, 320), bool)
    ground[60:] = True
    grown = grow_road(img, seeds, ground=ground)
    road = np.zeros_like(seeds)
    road[60:, 80:240] = True
    assert (grown & road).sum() > 0.98 * road.sum()
    near = np.zeros_like(road)
    near[58:, 78:242] = True  # the half-resolution fill may cross the edge by 2 px
    assert not (grown & ~near).any()


def test_the_lobe_joins_the_road_only_where_road_lies_on_both_sides():
    road = np.zeros((3, 8), bool)
    lobe = np.zeros((3, 8), bool)
    road[0, [0, 1, 6, 7]] = True  # row 0: road both sides of the lobe
    road[1, [0, 1]] = True  # row 1: road on the left only (the lobe at the road's edge)
    road[2, [6, 7]] = True  # row 2: road on the right only
    lobe[:, 2:6] = True
    expected = np.zeros((3, 8), bool)
    expected[0, 2:6] = True
    assert np.array_equal(_across_lobe(road, lobe), expected)


def test_grow_road_without_seeds_is_empty_and_rejects_bad_input():
    img = _scene()
    assert not grow_road(img, np.zeros((180, 320), bool)).any()
    with pytest.raises(SimroadError, match="tolerance"):
        grow_road(img, np.zeros((180, 320), bool), tolerance=-1.0)
    with pytest.raises(SimroadError, match="mask"):
        grow_road(img, np.zeros((10, 10), bool))
    with pytest.raises(SimroadError, match="image"):
        grow_road(img.astype(np.float32), np.zeros((180, 320), bool))


def test_the_light_filter_changes_no_mask_without_a_sun_lobe():
    from simroad.detector import RoadDetector
    from simroad.experiments.frames import collect_frames

    frames = collect_frames(scenarios=("racetrack", "town"), seeds=[7], frames_per_seed=2, every=6, noise="clear")
    plain, light = RoadDetector.pretrained(), RoadDetector.pretrained(filters=("light",))
    for img in frames.images:
        np.testing.assert_array_equal(light.predict(img), plain.predict(img))
