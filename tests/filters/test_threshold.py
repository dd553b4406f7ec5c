"""Otsu's threshold against a brute-force search of the between-class variance."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.filters._threshold import otsu_threshold, quantize_levels


def brute_force_otsu_level(levels: np.ndarray) -> int:
    """Level t maximising w0 w1 (mu0 - mu1)^2 for the split {<= t} | {> t}."""
    hist = np.bincount(levels.ravel(), minlength=256).astype(np.float64)
    values = np.arange(256, dtype=np.float64)
    best, best_t = -1.0, 0
    for t in range(255):
        w0, w1 = hist[: t + 1].sum(), hist[t + 1 :].sum()
        if w0 == 0 or w1 == 0:
            continue
        mu0 = (hist[: t + 1] * values[: t + 1]).sum() / w0
        mu1 = (hist[t + 1 :] * values[t + 1 :]).sum() / w1
        var_b = w0 * w1 * (mu0 - mu1) ** 2
        if var_b > best * (1 + 1e-12):
            best, best_t = var_b, t
    return best_t


@pytest.mark.parametrize("seed", range(6))
def test_otsu_split_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    n0, n1 = rng.integers(200, 2000, size=2)
    values = np.concatenate(
        [
            rng.normal(rng.uniform(-1, 0), rng.uniform(0.05, 0.3), n0),
            rng.normal(rng.uniform(0, 1), rng.uniform(0.05, 0.3), n1),
        ]
    )
    lo, hi = values.min(), values.max()
    levels = quantize_levels(values, lo, hi).ravel()
    t = brute_force_otsu_level(levels)
    np.testing.assert_array_equal(values > otsu_threshold(values), levels > t)


def test_otsu_separates_two_modes():
    rng = np.random.default_rng(1)
    low, high = rng.normal(0.2, 0.03, 500), rng.normal(0.8, 0.03, 300)
    t = otsu_threshold(np.concatenate([low, high]))
    assert low.max() < t < high.min()


@pytest.mark.parametrize("values", [np.full(50, 0.3), np.zeros((4, 4)), np.ones(1), np.array([])])
def test_otsu_on_constant_input_selects_nothing(values):
    assert not (values > otsu_threshold(values)).any()
