"""One table of invariants over every filter: pure, shape and dtype kept, deterministic,
robust to constant and tiny images, clear errors on bad input."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import (
    FilterResult,
    apply_filters,
    relight_shadows,
    remove_glare,
    remove_haze,
    remove_highlights,
    remove_rain_snow,
    remove_shadows,
)

#: Every public filter of the family (``remove_*``): one return convention.
PUBLIC = {
    "shadow": remove_shadows,
    "rain_snow": remove_rain_snow,
    "light": remove_highlights,
    "glare": remove_glare,
    "haze": remove_haze,
    "relight": relight_shadows,
}


def _image_only(fn):
    def run(image):
        return fn(image).image

    return run


FILTERS = {name: _image_only(fn) for name, fn in PUBLIC.items()}
FILTERS["pipeline"] = lambda image: apply_filters(image, ("shadow", "rain_snow", "light"))
FILTERS["pipeline, paper"] = lambda image: apply_filters(image, ("shadow", "rain_snow", "light"), variant="paper")
DTYPES = ("uint8", "float32", "float64")


def _scene(dtype: str, shape=(40, 64)) -> np.ndarray:
    """Sky, grass, asphalt with a marking, a cast shadow, a glare spot and snow flakes."""
    rng = np.random.default_rng(0)
    h, w = shape
    img = np.empty((h, w, 3))
    img[: h // 3] = (0.45, 0.6, 0.85)
    img[h // 3 :] = (0.34, 0.46, 0.23)
    img[h // 3 :, w // 4 : 3 * w // 4] = 0.35
    img[h // 3 :, w // 2 - 1 : w // 2 + 1] = 0.9
    img += rng.normal(0, 0.02, img.shape)
    img[h // 2 : h // 2 + 8, w // 4 : w // 2] *= (0.2, 0.25, 0.35)
    img[h - 8 :, w - 12 :] += 0.4
    img[rng.integers(0, h, 20), rng.integers(0, w, 20)] = 0.95
    img = np.clip(img, 0, 1)
    return (img * 255).round().astype(np.uint8) if dtype == "uint8" else img.astype(dtype)


def _constant(value: float, dtype: str, shape=(24, 32)) -> np.ndarray:
    img = np.full(shape + (3,), value)
    return (img * 255).round().astype(np.uint8) if dtype == "uint8" else img.astype(dtype)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("name", FILTERS)
def test_pure_shape_dtype_and_deterministic(name, dtype):
    fn = FILTERS[name]
    image = _scene(dtype)
    before = image.copy()
    out = fn(image)
    np.testing.assert_array_equal(image, before)  # input not mutated
    assert out.shape == image.shape and out.dtype == image.dtype
    assert out is not image and not np.shares_memory(out, image)
    np.testing.assert_array_equal(fn(image), out)  # deterministic
    if dtype != "uint8":
        assert np.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0


@pytest.mark.parametrize("name", FILTERS)
@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("value", [0.0, 1.0, 0.4])
def test_constant_images(name, dtype, value):
    image = _constant(value, dtype)
    out = FILTERS[name](image)
    assert out.shape == image.shape and out.dtype == image.dtype
    np.testing.assert_allclose(out.astype(float), image.astype(float), atol=1.0 if dtype == "uint8" else 1e-5)


@pytest.mark.parametrize("name", FILTERS)
def test_constant_colour_and_tiny_images(name):
    coloured = np.zeros((16, 16, 3), np.uint8) + np.array([200, 80, 20], np.uint8)
    assert FILTERS[name](coloured).shape == coloured.shape
    for shape in [(1, 1), (2, 3), (1, 50), (50, 1)]:
        tiny = _scene("float32", shape=(max(shape[0], 3), max(shape[1], 3)))[: shape[0], : shape[1]]
        tiny = np.ascontiguousarray(tiny)
        out = FILTERS[name](tiny)
        assert out.shape == tiny.shape and np.isfinite(out).all()


BAD = [
    (np.zeros((0, 0, 3), np.uint8), "at least 1x1"),
    (np.full((8, 8, 3), np.nan, np.float32), "NaN"),
    (np.zeros((8, 8, 3), np.int32), "dtype uint8 or float32 or float64, got int32"),
    (np.zeros((8, 8, 3), np.float16), "got float16"),
    (np.zeros((8, 8, 3), bool), "got bool"),
    (np.zeros((8, 8), np.uint8), r"shape \(H, W, 3\), got shape \(8, 8\)"),
    (np.zeros((8, 8, 4), np.uint8), r"got shape \(8, 8, 4\)"),
    (np.full((8, 8, 3), 1.5, np.float32), r"must lie in \[0, 1\]"),
    ([[0, 0, 0]], "expected a numpy array, got list"),
]


@pytest.mark.parametrize("name", FILTERS)
@pytest.mark.parametrize("bad,match", BAD)
def test_bad_input_is_a_clear_error(name, bad, match):
    with pytest.raises(SimroadError, match=match) as info:
        FILTERS[name](bad)
    assert str(info.value).startswith("image:")


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("name", PUBLIC)
def test_every_public_filter_returns_a_filter_result(name, dtype):
    image = _scene(dtype)
    result = PUBLIC[name](image)
    assert isinstance(result, FilterResult)
    out, mask = result  # unpacks like (image, mask)
    assert out is result.image and mask is result.mask
    assert mask.dtype == bool and mask.shape == image.shape[:2]


@pytest.mark.parametrize("name", PUBLIC)
def test_public_filter_options_are_keyword_only(name):
    params = list(inspect.signature(PUBLIC[name]).parameters.values())
    assert params[0].name == "image"
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params[1:])
    with pytest.raises(TypeError):
        PUBLIC[name](_scene("uint8"), 3)


@pytest.mark.parametrize("kwargs", [{}, {"tolerance": None}, {"achromatic": True, "tolerance": 0.02}])
def test_the_rain_snow_mask_is_exactly_the_changed_pixels(kwargs):
    image = _scene("float32")
    out, mask = remove_rain_snow(image, **kwargs)
    changed = (out != image).any(axis=-1)
    assert changed.any()
    np.testing.assert_array_equal(mask, changed)
