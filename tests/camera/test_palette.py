"""World palettes and ground textures: measured albedos, both cross-sections, no forced contrast."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad.camera.lighting import NOMINAL_EXPOSURE
from simroad.camera.materials import ALBEDO
from simroad.camera.palette import ROADSIDE_KINDS, SHOULDER_KINDS, aggregate_hue, draw_palette
from simroad.camera.textures import ground_textures, periodic_noise, wear_factor
from simroad.core.names import PROFILES
from simroad.errors import SimroadError


def _grey(rgb: np.ndarray) -> np.ndarray:
    hsv = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2HSV).astype(float) / 255.0
    return (hsv[..., 1] < 0.15) & (hsv[..., 2] > 0.15) & (hsv[..., 2] < 0.85)


def test_every_kind_and_both_ages_are_drawn_and_albedos_lie_in_measured_ranges():
    kinds, shoulders, ages, blue_over_red = set(), set(), [], []
    lo = np.mean(ALBEDO["asphalt_fresh"].lo) * 0.85
    hi = np.mean(ALBEDO["asphalt_aged"].hi) * 1.15
    for seed in range(200):
        p = draw_palette(np.random.default_rng(seed))
        kinds.add(p.roadside)
        shoulders.add(p.shoulder)
        ages.append(p.asphalt_age)
        a = np.asarray(p.asphalt)
        assert lo <= a.mean() <= hi
        blue_over_red.append(a[2] / a[0])
        assert 0.5 <= p.shoulder_width_m <= 2.5 and p.kerb_width_m == 0.0 and p.sidewalk_width_m == 0.0
    assert kinds == set(ROADSIDE_KINDS) and shoulders == set(SHOULDER_KINDS)
    assert min(ages) < 0.3 and max(ages) > 0.9
    # Grey-aggregate roads are nearly neutral, brown ones as the measured R/G ~ G/B ~ 1.2.
    assert max(blue_over_red) > 0.95 and min(blue_over_red) < 0.75


def test_aggregate_hue_keeps_the_mean_and_scales_the_chroma():
    brown = np.array([0.15, 0.125, 0.10], np.float32)
    np.testing.assert_allclose(aggregate_hue(brown, 0.0), [0.125] * 3, rtol=1e-6)
    np.testing.assert_allclose(aggregate_hue(brown, 1.0), brown, rtol=1e-6)
    np.testing.assert_allclose(aggregate_hue(brown, 0.5), [0.1375, 0.125, 0.1125], rtol=1e-6)


def test_urban_sidewalks_are_shaded_by_the_facades():
    """Same materials drawn, less sky: an urban sidewalk is darker than the rural draw of it."""
    ratios = []
    for seed in range(100):
        rural = draw_palette(np.random.default_rng(seed), roadside="grass", profile="rural")
        urban = draw_palette(np.random.default_rng(seed), roadside="grass", profile="urban")
        if rural.sidewalk_kind == urban.sidewalk_kind:
            ratios.append(np.mean(urban.sidewalk) / np.mean(rural.sidewalk))
    assert len(ratios) > 20
    assert 0.7 < min(ratios) and max(ratios) < 1.0


def test_roadside_can_be_as_dark_as_the_road():
    """No artificial luma margin: some worlds have a roadside darker than the asphalt."""
    darker = 0
    for seed in range(200):
        p = draw_palette(np.random.default_rng(seed))
        darker += np.mean(p.roadside_albedo) <= np.mean(p.asphalt)
    assert darker > 10


def test_urban_profile_has_kerb_and_sidewalk_of_measured_widths():
    for seed in range(50):
        p = draw_palette(np.random.default_rng(seed), profile="urban")
        assert p.profile == "urban" and p.shoulder_width_m == 0.0
        assert 0.15 <= p.kerb_width_m <= 0.3 and 1.5 <= p.sidewalk_width_m <= 4.0
        assert p.verge_width_m == pytest.approx(p.kerb_width_m + p.sidewalk_width_m)


def test_forced_roadside_kind_and_determinism():
    a = draw_palette(np.random.default_rng(3), roadside="gravel", profile="urban")
    b = draw_palette(np.random.default_rng(3), roadside="gravel", profile="urban")
    assert a == b and a.roadside == "gravel"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"roadside": "lawn"}, "roadside"), ({"profile": "city"}, "profile"), ({"profile": 3}, "profile")],
)
def test_bad_arguments_are_refused_by_name(kwargs, name):
    with pytest.raises(SimroadError, match=name):
        draw_palette(np.random.default_rng(0), **kwargs)


def test_periodic_noise_wraps_and_is_standardised():
    n = periodic_noise(256, 4.0, np.random.default_rng(0))
    assert n.dtype == np.float32 and abs(float(n.mean())) < 1e-3 and abs(float(n.std()) - 1.0) < 1e-3
    seam = np.abs(n[:, 0] - n[:, -1]).mean()
    inside = np.abs(np.diff(n, axis=1)).mean()
    assert seam < 1.3 * inside


@pytest.mark.parametrize("profile", PROFILES)
def test_textures_are_srgb_of_their_albedos(profile):
    rng = np.random.default_rng(1)
    p = draw_palette(rng, roadside="pavement", profile=profile)
    tex = ground_textures(p, 128, 0.1, rng)
    names = {"asphalt", "marking", "roadside"} | ({"kerb", "sidewalk"} if profile == "urban" else {"shoulder"})
    assert set(tex) == names
    for t in tex.values():
        assert t.dtype == np.uint8 and t.shape == (128, 128, 3)
    # Mean texel ~ NOMINAL_EXPOSURE * albedo, gamma-encoded (within texture variation).
    lin = (tex["roadside"].astype(float) / 255.0) ** 2.2 / NOMINAL_EXPOSURE
    assert np.mean(lin) == pytest.approx(np.mean(p.roadside_albedo), rel=0.25)


def test_brown_aggregate_shows_and_grey_asphalt_and_concrete_roadside_are_grey():
    brown, grey, side_grey = [], [], []
    for seed in range(16):
        rng = np.random.default_rng(seed)
        p = draw_palette(rng, roadside="pavement")
        tex = ground_textures(p, 128, 0.1, rng)
        a = np.asarray(p.asphalt)
        (brown if a[2] / a[0] < 0.75 else grey).append(_grey(tex["asphalt"]).mean())
        side_grey.append(_grey(tex["roadside"]).mean())
    assert len(brown) >= 2 and len(grey) >= 8
    assert np.mean(brown) < 0.9  # brown aggregate shows through worn binder
    assert min(grey) > 0.95  # grey stone: the texture's grain is lightness, not hue
    assert np.mean(side_grey) > 0.8  # concrete is as grey as any road


def test_wear_factor_is_identity_far_from_wheel_paths_and_darker_on_the_lane_centre():
    f = wear_factor(np.array([0.0, 1.2, 2.0]), age=1.0)
    assert f[0] == pytest.approx(1.0, abs=0.01)
    assert f[1] > 1.0 > f[2]


@pytest.mark.parametrize("size, scale", [(512, 40.0), (64, 2.5), (96, 0.6)])
def test_periodic_noise_is_the_rfft2_low_pass_bit_for_bit(size, scale):
    """The two-pass transform gives what numpy's rfft2 gives, to the last bit."""
    rng = np.random.default_rng(size)
    white = rng.standard_normal((size, size), dtype=np.float32)
    fy, fx = np.fft.fftfreq(size)[:, None], np.fft.rfftfreq(size)[None, :]
    lowpass = np.exp(-(fx**2 + fy**2) * (scale**2) * 2.0 * np.pi**2)
    lowpass[0, 0] = 0.0
    ref = np.fft.irfft2(np.fft.rfft2(white) * lowpass, s=(size, size))
    ref = (ref / (ref.std() + 1e-12)).astype(np.float32)
    np.testing.assert_array_equal(periodic_noise(size, scale, np.random.default_rng(size)), ref)
