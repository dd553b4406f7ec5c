"""The colour-cast step of the improved shadow filter: a von Kries balance beyond clear weather's colours."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import FILTER_REGISTRY, apply_filters, remove_colour_cast, remove_shadows
from simroad.filters.illuminant import CLEAR_CHROMATICITY

GAMMA = 2.2


def _scene(light):
    """Linear radiance: a sky over a grey road with a green verge, under ``light`` (R, G, B)."""
    lin = np.empty((60, 80, 3), np.float32)
    lin[:20] = (0.7, 0.7, 0.7)
    lin[20:] = (0.06, 0.12, 0.04)  # verge
    lin[20:, 20:60] = (0.20, 0.18, 0.16)  # warm grey asphalt
    return lin * np.asarray(light, np.float32)


def _encode(lin):
    return np.clip(lin, 0, 1) ** (1 / GAMMA)


def _chroma(lin, rows=0.4):
    m = lin[int(lin.shape[0] * (1 - rows)) :].reshape(-1, 3).astype(np.float64).mean(0)
    return math.log(m[2] / m[0]), math.log(m[1] / m[0]), m.sum()


def _box_around_white():
    """A box of half-width 0.1 around the scene's own chromaticity under white light."""
    b, g, _ = _chroma(_scene((1.0, 1.0, 1.0)))
    return ((b - 0.1, b + 0.1), (g - 0.1, g + 0.1))


BOX = _box_around_white()


def test_a_frame_inside_the_box_is_returned_unchanged():
    image = _encode(_scene((1.0, 1.0, 1.0)))
    out = remove_colour_cast(image, chromaticity=BOX, gamma=GAMMA)
    assert np.array_equal(out.image, image) and out.image is not image and not out.mask.any()


def test_a_blue_light_is_balanced_to_the_target_keeping_brightness():
    blue = (1.0, 1.02, 1.5)  # sun and blue sky instead of overcast
    lin = _scene(blue)
    b0, g0, s0 = _chroma(lin)
    assert b0 > BOX[0][1] and BOX[1][0] < g0 < BOX[1][1]  # outside the box (in log B/R)
    white = _chroma(_scene((1.0, 1.0, 1.0)))[:2]
    out = remove_colour_cast(_encode(lin), chromaticity=BOX, target=white, gamma=GAMMA)
    b1, g1, s1 = _chroma(out.image.astype(np.float64) ** GAMMA)
    # the scene's colours under white light come back: the cast is undone
    assert (b1, g1) == pytest.approx(white, abs=2e-3)
    assert s1 == pytest.approx(s0, rel=2e-3)  # the balanced rows keep their brightness
    assert out.mask.all()
    # von Kries: one diagonal map for every pixel, so the road is as grey as under the box's edge
    ratio = out.image.astype(np.float64) ** GAMMA / lin
    assert np.allclose(ratio[20:], ratio[30, 40], rtol=1e-3)  # (the sky clipped at 1)


def test_uint8_frames_and_the_shadow_filter_pipeline():
    lin = _scene((1.0, 1.02, 1.5))
    image = (_encode(lin) * 255 + 0.5).astype(np.uint8)
    out = remove_colour_cast(image, chromaticity=BOX)
    assert out.image.dtype == np.uint8 and out.image.shape == image.shape
    steps = FILTER_REGISTRY["shadow"].steps("improved")
    assert steps[0].function is remove_colour_cast and steps[0].options["chromaticity"] == CLEAR_CHROMATICITY
    assert FILTER_REGISTRY["shadow"].steps("paper")[0].function.__name__ == "remove_shadows"
    # the paper's variant never balances
    assert np.array_equal(apply_filters(image, ("shadow",), variant="paper"), remove_shadows(image).image)
    balanced = remove_shadows(remove_colour_cast(image).image).image
    assert np.array_equal(apply_filters(image, ("shadow",)), balanced)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rows": 0.0}, "rows"),
        ({"rows": 1.5}, "rows"),
        ({"gamma": 5.0}, "gamma"),
        ({"chromaticity": (0.1, 0.2)}, "chromaticity"),
        ({"chromaticity": ((0.2, 0.1), (0.0, 0.1))}, "chromaticity"),
        ({"chromaticity": ((float("nan"), 0.1), (0.0, 0.1))}, "chromaticity"),
        ({"target": (0.1,)}, "target"),
        ({"target": (0.1, 9.0)}, "target"),
    ],
)
def test_bad_options_are_refused_by_name(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        remove_colour_cast(np.zeros((8, 8, 3), np.uint8), **kwargs)
