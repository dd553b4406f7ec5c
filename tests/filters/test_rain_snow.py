"""The rain/snow filter (eqs. 21-22) and its handling of grey asphalt."""

from __future__ import annotations

import cv2
import numpy as np

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
    out = remove_rain_snow(snowy)
    err_before = np.abs(snowy - clean)[flakes].mean()
    err_after = np.abs(out - clean)[flakes].mean()
    assert err_after < 0.5 * err_before
    assert np.abs(out - clean)[~flakes].mean() < 0.01


def test_output_only_darkens_and_keeps_most_of_a_clean_grey_road():
    clean = _road(np.random.default_rng(1))
    out = remove_rain_snow(clean)
    assert (out <= clean).all()  # rain and snow only ever brighten, so the filter only darkens
    unchanged = (out == clean).all(axis=-1).mean()
    plain = remove_rain_snow(clean, tolerance=None)  # Xu et al. alone: a box blur on grey
    assert unchanged > 0.7  # texture 1 sigma above the local mean is kept (tolerance 0.02)
    assert (plain == clean).all(axis=-1).mean() < 0.1
    assert np.abs(out - clean).mean() < 0.25 * np.abs(plain - clean).mean()
