"""Dark channel (eq. 24), specular-to-diffuse (eq. 27) and the highlight filter."""

from __future__ import annotations

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import dark_channel, remove_highlights, specular_to_diffuse
from simroad.filters._common import to_planes
from simroad.filters.highlights import _diffuse_planes, _max_diffuse_chromaticity


def dark_channel_loop(image: np.ndarray, patch: int) -> np.ndarray:
    h, w = image.shape[:2]
    r = patch // 2
    out = np.empty((h, w), image.dtype)
    for i in range(h):
        for j in range(w):
            out[i, j] = image[max(0, i - r) : i + r + 1, max(0, j - r) : j + r + 1].min()
    return out


@pytest.mark.parametrize("patch", [1, 3, 5, 15])
@pytest.mark.parametrize("dtype", ["uint8", "float32"])
def test_dark_channel_matches_naive_loop(patch, dtype):
    rng = np.random.default_rng(patch)
    img = rng.integers(0, 256, (13, 17, 3)).astype(np.uint8)
    if dtype == "float32":
        img = (img / 255).astype(np.float32)
    got = dark_channel(img, patch=patch)
    assert got.dtype == img.dtype and got.shape == img.shape[:2]
    np.testing.assert_array_equal(got, dark_channel_loop(img, patch))


def test_dark_channel_rejects_even_patch():
    with pytest.raises(SimroadError, match=r"patch: expected an odd window size, got 4\. Use 5\."):
        dark_channel(np.zeros((5, 5, 3), np.uint8), patch=4)


def test_eq27_recovers_the_diffuse_colour_of_a_constructed_pixel():
    diffuse = np.array([0.5, 0.3, 0.1])
    lam = diffuse.max() / diffuse.sum()  # maximum diffuse chromaticity = 5/9
    image = (diffuse + 0.2).reshape(1, 1, 3).astype(np.float32)  # white specular w_s G = 0.2
    got = specular_to_diffuse(image, np.full((1, 1), lam, np.float32))
    np.testing.assert_allclose(got[0, 0], diffuse, atol=1e-6)
    # Worked by hand: max = 0.7, sum = 1.5, (0.7 - 5/9 * 1.5) / (1 - 5/3) = 0.2.


def test_eq27_leaves_achromatic_and_diffuse_pixels_alone():
    grey = np.full((1, 1, 3), 0.6, np.float32)
    np.testing.assert_array_equal(specular_to_diffuse(grey, np.full((1, 1), 1 / 3, np.float32)), grey)
    pixel = np.array([[[0.5, 0.3, 0.1]]], np.float32)  # Lambda = its own chromaticity: no specular
    np.testing.assert_allclose(specular_to_diffuse(pixel, np.full((1, 1), 5 / 9, np.float32)), pixel, atol=1e-6)


def test_eq27_rejects_impossible_chromaticity():
    with pytest.raises(SimroadError, match="lambda_max"):
        specular_to_diffuse(np.zeros((2, 2, 3), np.float32), np.full((2, 2), 0.2, np.float32))


def _orange_with_highlight(grey: bool = False):
    yy, xx = np.mgrid[0:48, 0:48].astype(np.float32)
    body = np.array([0.33, 0.33, 0.33] if grey else [0.6, 0.35, 0.15], np.float32)
    shading = 0.75 + 0.25 * np.cos(xx / 13.0) * np.cos(yy / 17.0)  # w_d: keeps chromaticity
    diffuse = shading[..., None] * body
    specular = 0.35 * np.exp(-((xx - 24) ** 2 + (yy - 24) ** 2) / (2 * 4.0**2))  # w_s, white G
    return np.clip(diffuse + specular[..., None], 0, 1).astype(np.float32), diffuse.astype(np.float32), specular > 0.05


def test_remove_highlights_recovers_diffuse_colour_of_a_chromatic_surface():
    image, diffuse, spot = _orange_with_highlight()
    out, mask = remove_highlights(image)
    assert mask[spot].mean() > 0.9
    before = np.abs(image - diffuse)[spot].mean()
    after = np.abs(out - diffuse)[spot].mean()
    assert after < 0.2 * before


def test_remove_highlights_keeps_achromatic_surfaces():
    image, _, _ = _orange_with_highlight(grey=True)
    out, _ = remove_highlights(image)
    np.testing.assert_array_equal(out, image)


@pytest.mark.parametrize("subsample,atol", [(1, 1e-6), (2, 0.02)])
def test_chromaticity_estimate_on_the_highlight_box_equals_the_whole_image(subsample, atol):
    image, _, _spot = _orange_with_highlight()
    image = np.pad(image, ((0, 40), (30, 0), (0, 0)), mode="reflect")
    planes = to_planes(image)
    full = _max_diffuse_chromaticity(planes, 8, 1e-4, 2, subsample)
    out, mask = remove_highlights(image, radius=8, eps=1e-4, iterations=2, subsample=subsample)
    assert mask.mean() < 0.5
    expect = np.stack(_diffuse_planes(planes, full, 0.1), axis=-1)
    np.testing.assert_allclose(out[mask], np.clip(expect, 0, 1)[mask], atol=atol)
