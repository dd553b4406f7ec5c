"""Fog: Koschmieder's law, checked on synthetic frames of known depth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.core.radiometry import srgb_to_linear
from simroad.noise import FogParams, apply_noise
from simroad.noise.fog import extinction_from_visibility, koschmieder


def _stripes(depth_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A float frame of dark/bright column pairs; each block of rows at one depth."""
    h, w = 16 * len(depth_m), 64
    img = np.empty((h, w, 3), dtype=np.float32)
    img[:, 0::2] = 0.15
    img[:, 1::2] = 0.85
    depth = np.repeat(np.asarray(depth_m, dtype=np.float32), 16)[:, None].repeat(w, axis=1)
    return img, depth


def test_contrast_falls_as_exp_of_minus_beta_distance():
    d = np.array([5.0, 20.0, 60.0, 150.0, 400.0])
    img, depth = _stripes(d)
    vis = 200.0
    out, _ = apply_noise(img, "fog", rng=0, depth=depth, params={"fog": FogParams(visibility_m=vis)})
    lin_in, lin_out = srgb_to_linear(img), srgb_to_linear(out)
    contrast = lambda lin: (lin[:, 1::2] - lin[:, 0::2]).reshape(len(d), 16, -1, 3).mean(axis=(1, 2, 3))  # noqa: E731
    np.testing.assert_allclose(contrast(lin_out) / contrast(lin_in), np.exp(-3.912 / vis * d), rtol=1e-4, atol=1e-6)


def test_visibility_is_where_contrast_drops_to_two_percent():
    vis = 120.0
    beta = extinction_from_visibility(vis)
    assert beta == pytest.approx(3.912 / vis)
    assert math.exp(-beta * vis) == pytest.approx(0.02, rel=1e-3)


def test_far_surfaces_and_the_sky_turn_to_airlight():
    lin = np.full((4, 4, 3), 0.1, dtype=np.float32)
    depth = np.full((4, 4), np.inf, dtype=np.float32)
    depth[:2] = 1e4
    koschmieder(lin, depth, 0.05, 0.7, sky_path_m=1000.0)
    np.testing.assert_allclose(lin, 0.7, atol=1e-6)


def test_near_surfaces_barely_change():
    img = np.full((32, 32, 3), 0.3, dtype=np.float32)
    depth = np.full((32, 32), 0.5, dtype=np.float32)
    out, masks = apply_noise(img, "fog", rng=0, depth=depth, params={"fog": FogParams(visibility_m=300.0)})
    assert np.abs(out - img).max() < 2 / 255
    assert not masks["fog"].any()
