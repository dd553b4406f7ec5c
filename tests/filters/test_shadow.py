"""NDI (eq. 13) and the shadow filter (Otsu, regions, buffer-ring correction)."""

from __future__ import annotations

import numpy as np

from simroad.filters import ndi, remove_shadows


def test_ndi_hand_worked_pixels():
    img = np.array([[[0.8, 0.4, 0.2], [0.5, 0.5, 0.5], [0.0, 0.0, 0.0], [0.1, 0.15, 0.3]]], np.float32)
    # (0.8, 0.4, 0.2): V = 1.4/3, S = 1 - 0.6/1.4 = 4/7.  grey: S = 0.  black: 0 by convention.
    v, s = 1.4 / 3, 4 / 7
    v4, s4 = 0.55 / 3, 1 - 0.3 / 0.55
    expect = [(s - v) / (s + v), -1.0, 0.0, (s4 - v4) / (s4 + v4)]
    np.testing.assert_allclose(ndi(img)[0], expect, atol=1e-6)


def _asphalt(rng, shape=(60, 90)):
    return np.clip(0.4 + rng.normal(0, 0.02, shape + (1,)) + rng.normal(0, 0.004, shape + (3,)), 0, 1).astype(np.float32)


def test_remove_shadows_relights_a_cast_shadow():
    rng = np.random.default_rng(0)
    lit = _asphalt(rng)
    shadow = np.zeros(lit.shape[:2], bool)
    shadow[20:45, 30:70] = True
    image = lit.copy()
    image[shadow] *= np.array([0.2, 0.25, 0.35], np.float32)  # skylight only: bluish, dark
    out, mask = remove_shadows(image)
    iou = (mask & shadow).sum() / (mask | shadow).sum()
    assert iou > 0.95
    # I' = mu_buff + (sigma_buff / sigma_k)(I - mu_k): region mean and spread become the ring's.
    np.testing.assert_allclose(out[shadow].mean(axis=0), lit[~shadow].mean(axis=0), atol=0.01)
    np.testing.assert_allclose(out[shadow].std(axis=0), lit[~shadow].std(axis=0), rtol=0.25)
    np.testing.assert_array_equal(out[~mask], image[~mask])


def test_remove_shadows_leaves_a_shadowless_frame_alone():
    rng = np.random.default_rng(1)
    image = _asphalt(rng)
    image[:, :40] = np.clip(np.array([0.34, 0.46, 0.23]) + rng.normal(0, 0.03, (60, 40, 3)), 0, 1)  # grass
    out, mask = remove_shadows(image)
    assert not mask.any()  # Otsu splits grass from asphalt, but grass is not darker: no shadow
    np.testing.assert_array_equal(out, image)


def test_remove_shadows_ignores_tiny_regions():
    image = _asphalt(np.random.default_rng(2))
    image[10:13, 10:13] *= np.array([0.2, 0.25, 0.35], np.float32)  # 9 px < min_area
    out, mask = remove_shadows(image, min_area=16)
    assert not mask.any()
    np.testing.assert_array_equal(out, image)
