"""The haze step of the rain/snow filter: Koschmieder's law undone row by row."""

from __future__ import annotations

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import remove_haze

GAMMA = 2.2
H, W, HORIZON = 96, 128, 24


def _scene(rng=None):
    """Linear radiance of a level camera's view: sky above ``HORIZON``; below it a
    dark road in the middle third and a pale roadside either side."""
    lin = np.empty((H, W, 3), np.float32)
    lin[:HORIZON] = (0.80, 0.80, 0.82)
    lin[HORIZON:] = (0.30, 0.28, 0.24)  # roadside
    lin[HORIZON:, W // 3 : 2 * W // 3] = (0.05, 0.05, 0.055)  # asphalt
    if rng is not None:
        lin[HORIZON:] *= 1.0 + rng.normal(0.0, 0.02, (H - HORIZON, W, 1)).astype(np.float32)
    return lin


def _transmission():
    """Koschmieder over flat ground: d = k / (row - horizon), t = exp(-beta d); 1 on the sky."""
    rows = np.arange(H, dtype=np.float64)
    d = 400.0 / np.maximum(rows - HORIZON + 1, 1)
    t = np.exp(-0.006 * d)
    t[:HORIZON] = 1.0
    return t.astype(np.float32)[:, None, None]


def _encode(lin):
    return np.clip(lin, 0, 1) ** (1 / GAMMA)


def test_a_worked_veil_is_removed_from_the_road():
    """Haze a scene with a known row transmission (I = J t + A (1 - t), the airlight A
    being the sky). The filter takes the nearest rows as clear air, so the far road
    must come back to the colour of the near road (the bottom rows); before, it is
    the pale grey of the veil. Near rows are left as they were."""
    clean = _scene()
    airlight = clean[0, 0]
    t = _transmission()
    hazy = _encode(clean * t + airlight * (1 - t)).astype(np.float32)
    out = remove_haze(hazy).image
    road = slice(W // 3 + 2, 2 * W // 3 - 2)
    restorable = np.flatnonzero((t[:, 0, 0] > 0.55) & (np.arange(H) >= HORIZON + 4))
    assert t[restorable].min() < 0.7  # a strong veil on these rows: the case is not trivial
    near_road = hazy[H - 4 :, road].mean(axis=(0, 1))
    before = np.abs(hazy[restorable, road] - near_road).max()
    after = np.abs(out[restorable, road] - near_road).max()
    assert before > 0.15 and after < 0.03, (before, after)
    np.testing.assert_allclose(out[H - 6 :], hazy[H - 6 :], atol=0.01)


def test_a_clear_scene_is_returned_unchanged():
    clear = (_encode(_scene(np.random.default_rng(3))) * 255).round().astype(np.uint8)
    out = remove_haze(clear).image
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(out, clear)


def test_a_pale_thing_across_a_few_near_rows_is_not_a_veil():
    """Three rows below the middle lifted across the whole width (a pale car's flank
    across the road, a crest between pale verges): their floor rises 0.4 above the
    road's, which a running maximum of the floor would spread as a veil over every row
    above. A veil grows with distance, so the monotone fit of the floor must rise over
    the near half of the rows: a bump this short does not lift it, and the frame is
    returned as it is. The same scene under a real veil is still corrected."""
    clean = _scene()
    clean[62:65] = (0.45, 0.45, 0.45)
    frame = _encode(clean).astype(np.float32)
    kept = remove_haze(frame, tolerance=0.045)
    assert not kept.mask.any()
    np.testing.assert_array_equal(kept.image, frame)
    t = _transmission()
    hazy = _encode(clean * t + clean[0, 0] * (1 - t)).astype(np.float32)
    assert remove_haze(hazy, tolerance=0.045).mask[HORIZON + 4 : H // 2].all()


def test_under_a_blue_sky_the_frame_is_left_alone():
    """A blue sky means clear air: the rise of a far row's floor is not haze then."""
    clean = _scene()
    clean[:HORIZON] = (0.25, 0.45, 0.85)  # saturation 1 - min/mean ~ 0.52
    t = _transmission()
    hazy = _encode(clean * t + clean[0, 0] * (1 - t)).astype(np.float32)
    np.testing.assert_array_equal(remove_haze(hazy).image, hazy)


def test_input_is_not_modified_and_dtype_kept():
    t = _transmission()
    hazy = _encode(_scene() * t + 0.8 * (1 - t))
    for dtype in (np.float32, np.float64):
        img = hazy.astype(dtype)
        copy = img.copy()
        out = remove_haze(img).image
        assert out.dtype == dtype and out.shape == img.shape
        np.testing.assert_array_equal(img, copy)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"percentile": 80}, "percentile"),
        ({"t_min": 0.0}, "t_min"),
        ({"tolerance": -1}, "tolerance"),
        ({"gamma": 5}, "gamma"),
    ],
)
def test_bad_parameters_are_named(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        remove_haze(np.zeros((16, 16, 3), np.uint8), **kwargs)


def test_bad_images_are_named():
    with pytest.raises(SimroadError, match="image"):
        remove_haze(np.full((16, 16, 3), np.nan, np.float32))
    with pytest.raises(SimroadError, match="image"):
        remove_haze(np.zeros((16, 16), np.uint8))
