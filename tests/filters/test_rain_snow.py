"""The rain/snow filter (eqs. 21-22) and its handling of grey asphalt."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import remove_rain_snow


def _road(rng):
    img = np.clip(0.35 + rng.normal(0, 0.02, (64, 96, 1)) + rng.normal(0, 0.004, (64, 96, 3)), 0, 1)
    img[:, 40:50] = 0.85  # a white lane marking, wider than the filter window
    return img.astype(np.float32)


def _snow(clean, rng, n=60):
    """Flakes blended by exposure (eq. 19): I = beta I_E + (1 - beta) I_b."""
    alpha = np.zeros(clean.shape[:2], np.float32)
    for x, y in zip(rng.integers(0, 96, n), rng.integers(0, 64, n)):
        cv2.circle(alpha, (int(x), int(y)), 1, 0.35, -1)
    return clean * (1 - alpha[..., None]) + 0.95 * alpha[..., None], alpha > 0


def test_snow_is_reduced_and_the_rest_kept():
    rng = np.random.default_rng(0)
    clean = _road(rng)
    snowy, flakes = _snow(clean, rng)
    out = remove_rain_snow(snowy).image
    err_before = np.abs(snowy - clean)[flakes].mean()
    err_after = np.abs(out - clean)[flakes].mean()
    assert err_after < 0.5 * err_before
    assert np.abs(out - clean)[~flakes].mean() < 0.01


def test_output_only_darkens_and_keeps_most_of_a_clean_grey_road():
    clean = _road(np.random.default_rng(1))
    out = remove_rain_snow(clean).image
    assert (out <= clean).all()  # rain and snow only ever brighten, so the filter only darkens
    unchanged = (out == clean).all(axis=-1).mean()
    plain = remove_rain_snow(clean, tolerance=None).image  # Xu et al. alone: a box blur on grey
    assert unchanged > 0.7  # texture 1 sigma above the local mean is kept (tolerance 0.02)
    assert (plain == clean).all(axis=-1).mean() < 0.1
    assert np.abs(out - clean).mean() < 0.25 * np.abs(plain - clean).mean()


# ------------------------------------------------------------- achromatic variant
def _snow_cover_with_flakes(seed=0):
    """A faintly blue snow cover with achromatic texture, and white 1-px flakes."""
    rng = np.random.default_rng(seed)
    base = np.array([0.80, 0.82, 0.88], np.float32)
    texture = rng.normal(0.0, 0.02, (60, 80, 1)).astype(np.float32)
    clean = np.clip(base + texture, 0, 1)
    img = clean.copy()
    ys, xs = rng.integers(2, 58, 40), rng.integers(2, 78, 40)
    img[ys, xs] = 1.0
    return img, clean, (ys, xs)


def test_achromatic_variant_keeps_the_chroma_of_a_surface_and_removes_flakes():
    img, clean, (ys, xs) = _snow_cover_with_flakes()
    out = remove_rain_snow(img, achromatic=True, tolerance=0.04, radius=3).image
    # every output pixel differs from its input by the same amount in all channels
    d = img - out
    np.testing.assert_allclose(d[..., 0], d[..., 2], atol=1e-6)
    np.testing.assert_allclose(d[..., 0], d[..., 1], atol=1e-6)
    assert (d >= -1e-6).all()  # only ever darkens (eq. 19: drops brighten)
    # the surface's blue tint (B - R) is exactly kept
    np.testing.assert_allclose((out[..., 2] - out[..., 0]), (img[..., 2] - img[..., 0]), atol=1e-6)
    # flakes are pulled most of the way back to the cover
    before = np.abs(img[ys, xs] - clean[ys, xs]).mean()
    after = np.abs(out[ys, xs] - clean[ys, xs]).mean()
    assert after < 0.6 * before


def test_protect_keeps_a_lane_marking_that_the_plain_variant_dims():
    img = np.full((40, 60, 3), 0.3, np.float32)
    img[:, 28:36] = 0.95  # an 8-px stripe: paint, not a particle
    img[5, 5] = 1.0  # a 1-px flake
    plain = remove_rain_snow(img, achromatic=True, tolerance=0.02, radius=3).image
    kept = remove_rain_snow(img, achromatic=True, tolerance=0.02, radius=3, protect=5).image
    assert plain[20, 28:36].mean() < 0.9  # the stripe's edges are dimmed without protection
    np.testing.assert_allclose(kept[:, 28:36], img[:, 28:36], atol=1e-6)
    assert kept[5, 5, 0] < 0.8  # the flake still goes


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"achromatic": True, "tolerance": None}, "tolerance: the achromatic variant needs a tolerance"),
        ({"achromatic": "yes"}, "achromatic: expected True or False"),
        ({"achromatic": True, "protect": 40}, "protect"),
    ],
)
def test_achromatic_variant_rejects_bad_parameters(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        remove_rain_snow(np.zeros((20, 20, 3), np.uint8), **kwargs)
