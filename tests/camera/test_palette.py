"""World palettes: varied, but asphalt always darker than what borders it."""

from __future__ import annotations

import numpy as np

from simroad.camera.palette import MIN_LUMA_MARGIN, ROADSIDE_KINDS, _luma, draw_palette, make_texture


def test_asphalt_is_darker_than_shoulder_and_non_green_roadside():
    kinds = set()
    for seed in range(300):
        p = draw_palette(np.random.default_rng(seed))
        kinds.add(p.roadside)
        assert _luma(p.shoulder_rgb) >= _luma(p.asphalt_rgb) + MIN_LUMA_MARGIN - 1
        if p.roadside != "grass":
            assert _luma(p.roadside_rgb) >= _luma(p.asphalt_rgb) + MIN_LUMA_MARGIN - 1
    assert kinds == set(ROADSIDE_KINDS)


def test_forced_roadside_kind_and_determinism():
    a = draw_palette(np.random.default_rng(3), roadside="gravel")
    b = draw_palette(np.random.default_rng(3), roadside="gravel")
    assert a == b and a.roadside == "gravel"


def test_texture_is_periodic_and_centred_on_its_colour():
    tex = make_texture((100, 120, 80), 64, np.random.default_rng(0), grain=6.0, blotch=5.0, blotch_scale_px=8.0)
    assert tex.shape == (64, 64, 3)
    np.testing.assert_allclose(tex.reshape(-1, 3).mean(axis=0), (100, 120, 80), atol=3.0)
