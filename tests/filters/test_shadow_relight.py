"""The physically based shadow relighting (simroad.filters.relight), checked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.core.radiometry import linear_to_srgb, srgb_to_linear
from simroad.filters import relight_shadows

H, W = 120, 200
SKY_BLUE = (0.35, 0.55, 0.9)  # linear, log B/R = 0.94: a clear sky
SKY_GREY = (0.8, 0.8, 0.82)  # linear, log B/R = 0.02: overcast
ASPHALT = np.array([0.12, 0.114, 0.108])  # lit linear signal
# Sun/sky ratio r = (6.4, 4.8, 2.4) at elevation 28 deg (simroad's shadow 0.8):
# k = 1 / (r sin e + 1) = 1 / (4.005, 3.253, 2.127) = (0.2497, 0.3074, 0.4702).
K = 1.0 / (np.array([6.4, 4.8, 2.4]) * math.sin(math.radians(28.0)) + 1.0)


def _encode(linear: np.ndarray) -> np.ndarray:
    """The camera's response with shoulder 1, ``2y / (1 + y)``, then sRGB to uint8."""
    return linear_to_srgb((2.0 * linear / (1.0 + linear)).astype(np.float32))


def _decode(image: np.ndarray) -> np.ndarray:
    r = srgb_to_linear(image).astype(np.float64)
    return r / (2.0 - r)


def _scene(sky, shadow: np.ndarray | None, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lin = np.empty((H, W, 3))
    lin[: H // 3] = sky
    ground = ASPHALT * (1.0 + rng.normal(0.0, 0.03, (H - H // 3, W, 1)))
    lin[H // 3 :] = ground
    if shadow is not None:
        lin *= 1.0 - shadow[..., None] * (1.0 - K)
    return _encode(lin)


def _shadow() -> np.ndarray:
    """A cast shadow touching the bottom border, with a 5 px penumbra ramp on its sides."""
    cover = np.zeros((H, W))
    cover[85:, 70:140] = 1.0
    ramp = np.linspace(0.0, 1.0, 7)[1:-1]
    cover[85:, 65:70] = ramp
    cover[85:, 140:145] = ramp[::-1]
    cover[80:85, 65:145] *= 0.0
    cover[80:85, 70:140] = ramp[:, None]
    return cover


def test_k_worked_by_hand():
    np.testing.assert_allclose(K, [0.2497, 0.3074, 0.4702], atol=1e-4)


def test_a_shadow_of_known_ratio_is_relit():
    cover = _shadow()
    image = _scene(SKY_BLUE, cover)
    out, mask = relight_shadows(image)
    core = np.zeros((H, W), bool)
    core[90:, 75:135] = True
    assert mask[core].mean() > 0.99
    lit = _decode(_scene(SKY_BLUE, None))
    # Dividing the core by the estimated k brings it back to the lit asphalt within 6 %.
    np.testing.assert_allclose(_decode(out)[core].mean(axis=0), lit[core].mean(axis=0), rtol=0.06)
    # Before: the core was k times the lit level.
    np.testing.assert_allclose(_decode(image)[core].mean(axis=0) / lit[core].mean(axis=0), K, rtol=0.06)
    # Far from the shadow nothing moves.
    far = np.ones((H, W), bool)
    far[70:, 50:160] = False
    np.testing.assert_array_equal(out[far], image[far])
    assert not mask[far].any()


def test_frames_without_shadows_pass_bit_identical():
    # Overcast sky: a dark bluish repair patch is not taken for a shadow.
    patch = np.zeros((H, W))
    patch[85:, 70:140] = 1.0
    for sky, cover in ((SKY_GREY, patch), (SKY_BLUE, None), (SKY_GREY, None)):
        image = _scene(sky, cover)
        out, mask = relight_shadows(image)
        assert not mask.any()
        np.testing.assert_array_equal(out, image)
    grey = np.full((H, W, 3), 0.4, np.float32)
    np.testing.assert_array_equal(relight_shadows(grey).image, grey)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("shoulder", -1.0),
        ("rows", 0.0),
        ("sky_rows", 1.5),
        ("min_sky_blue", float("nan")),
        ("min_drop", 0.0),
        ("min_pairs", 0),
        ("window", 2),
        ("window", 3.5),
    ],
)
def test_bad_options_are_refused_by_name(option, value):
    with pytest.raises(SimroadError, match=option):
        relight_shadows(_scene(SKY_BLUE, None), **{option: value})
