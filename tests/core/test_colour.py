"""HSI intensity and saturation (eqs. 10-11): worked values, dtypes, the black guard."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.core.colour import hsi_intensity, hsi_saturation


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_worked_values_and_dtype(dtype):
    rgb = np.array([[0.6, 0.3, 0.0], [0.5, 0.5, 0.5], [0.0, 0.0, 0.0], [0.9, 0.6, 0.3]], dtype)
    total, darkest = rgb.sum(axis=1), rgb.min(axis=1)
    inten = hsi_intensity(total)
    sat = hsi_saturation(total, darkest, tiny=1e-6)
    assert inten.dtype == sat.dtype == dtype
    np.testing.assert_allclose(inten, [0.3, 0.5, 0.0, 0.6], rtol=1e-6)
    np.testing.assert_allclose(sat, [1.0, 0.0, 0.0, 0.5], atol=1e-6)  # black: 0, not 0/0


def test_the_filters_and_the_features_share_it():
    """The shadow filter's NDI and the detector's HSI agree on S and V."""
    from simroad.detector import hsi
    from simroad.filters import ndi

    rgb = np.random.default_rng(0).integers(0, 256, (8, 8, 3), dtype=np.uint8)
    h = hsi(rgb).astype(np.float64)
    s, v = h[..., 1], h[..., 2]
    np.testing.assert_allclose(ndi(rgb), (s - v) / np.maximum(s + v, 1e-6), atol=1e-5)
