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
    img = 0.4 + rng.normal(0, 0.02, shape + (1,)) + rng.normal(0, 0.004, shape + (3,))
    return np.clip(img, 0, 1).astype(np.float32)


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


def test_remove_shadows_ignores_darker_but_redder_surfaces():
    rng = np.random.default_rng(3)
    image = np.clip(0.6 + rng.normal(0, 0.02, (60, 90, 1)) + rng.normal(0, 0.004, (60, 90, 3)), 0, 1)
    image[20:45, 30:70] = np.clip(np.array([0.43, 0.33, 0.24]) + rng.normal(0, 0.02, (25, 40, 3)), 0, 1)  # dirt
    image = image.astype(np.float32)
    out, mask = remove_shadows(image)
    assert not mask.any()  # darker than the pavement ring, but redder: not a shadow
    np.testing.assert_array_equal(out, image)


def test_gain_is_capped_by_the_illumination_ratio():
    rng = np.random.default_rng(4)
    lit = _asphalt(rng)
    lit[:, 60:] = np.clip(0.75 + rng.normal(0, 0.08, (60, 30, 3)), 0, 1)  # a rough, bright neighbour
    shadow = np.zeros(lit.shape[:2], bool)
    shadow[20:45, 35:58] = True  # on asphalt; its buffer ring reaches the rough neighbour
    image = lit.copy()
    image[shadow] *= np.array([0.3, 0.35, 0.45], np.float32)
    out, mask = remove_shadows(image)
    assert mask[shadow].mean() > 0.9
    # The mixed ring makes sigma_buff / sigma_k about 8; capped at mu_buff / mu_k the
    # relit texture stays close to the true lit texture instead of 2-3 times rougher.
    assert (out[shadow].std(axis=0) < 1.3 * lit[shadow].std(axis=0)).all()
