"""HSI (paper eqs. 10-12) on pixels worked by hand, incl. grey and black."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.detector import hsi, pixel_features

CASES = [
    # (R, G, B) in [0, 1] -> (H degrees, S, I)
    ((1.0, 0.0, 0.0), (0.0, 1.0, 1 / 3)),  # red: theta = arccos(1) = 0
    ((0.0, 1.0, 0.0), (120.0, 1.0, 1 / 3)),  # green: theta = arccos(-1/2) = 120, B <= G
    ((0.0, 0.0, 1.0), (240.0, 1.0, 1 / 3)),  # blue: theta = 120, B > G -> 360 - 120
    ((1.0, 1.0, 0.0), (60.0, 1.0, 2 / 3)),  # yellow: theta = arccos(1/2)
    # (0.8, 0.4, 0.2): num = 0.5 (0.4 + 0.6) = 0.5, den = sqrt(0.16 + 0.6 * 0.2) = sqrt(0.28)
    ((0.8, 0.4, 0.2), (math.degrees(math.acos(0.5 / math.sqrt(0.28))), 1 - 0.6 / 1.4, 1.4 / 3)),
    # (0.2, 0.4, 0.8): num = -0.4, den = sqrt(0.04 + 0.24); B > G -> 360 - theta
    ((0.2, 0.4, 0.8), (360 - math.degrees(math.acos(-0.4 / math.sqrt(0.28))), 1 - 0.6 / 1.4, 1.4 / 3)),
    ((0.5, 0.5, 0.5), (0.0, 0.0, 0.5)),  # grey: arccos 0/0 -> hue 0 by convention
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),  # black: S 0/0 as well -> 0
    ((1.0, 1.0, 1.0), (0.0, 0.0, 1.0)),  # white
]


@pytest.mark.parametrize("rgb,expect", CASES)
def test_hsi_hand_worked(rgb, expect):
    got = hsi(np.array([[rgb]], np.float64))[0, 0]
    np.testing.assert_allclose(got, expect, atol=1e-5)


def test_hsi_uint8_equals_float_and_hue_is_in_range():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (20, 30, 3)).astype(np.uint8)
    a, b = hsi(img), hsi((img / 255).astype(np.float32))
    assert a.dtype == np.float32 and a.shape == img.shape
    np.testing.assert_allclose(a, b, atol=1e-4)
    assert a[..., 0].min() >= 0 and a[..., 0].max() < 360


def test_pixel_features_are_intensity_and_the_chromatic_plane():
    img = np.array([[[0.8, 0.4, 0.2], [0.5, 0.5, 0.5]]], np.float32)
    h, s, i = hsi(img)[0].T
    feats = pixel_features(img)
    assert feats.shape == (2, 3)
    np.testing.assert_allclose(feats[:, 0], i, atol=1e-6)
    np.testing.assert_allclose(feats[:, 1], s * np.cos(np.radians(h)), atol=1e-6)
    np.testing.assert_allclose(feats[:, 2], s * np.sin(np.radians(h)), atol=1e-6)
    np.testing.assert_allclose(feats[1], [0.5, 0.0, 0.0], atol=1e-6)  # grey: no chroma


@pytest.mark.parametrize("bad", [np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.int64), np.full((2, 2, 3), np.nan)])
def test_hsi_rejects_bad_input(bad):
    with pytest.raises(SimroadError, match="image:"):
        hsi(bad)
