"""Rain: drop physics against published numbers, the wet road, coherent drops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from simroad.camera import ASPHALT
from simroad.core.radiometry import linear_to_srgb, srgb_to_linear
from simroad.noise import RainModel, RainParams, make_weather
from simroad.noise import _particles as pt
from simroad.noise._geometry import view_geometry
from simroad.noise._particle_field import wind_in_ego
from simroad.noise.rain import (
    exposure_beta,
    marshall_palmer,
    rain_extinction,
    terminal_velocity,
    wet_albedo,
)


def test_raindrop_beta_at_thirty_hz_is_at_most_five_percent():
    a = np.linspace(0.25e-3, 3.5e-3, 200)  # all raindrop radii
    beta = exposure_beta(a, terminal_velocity(a), 1 / 30)
    assert beta.max() <= 0.05
    # Garg & Nayar's worked case: a = 3.5 mm at v = 200·sqrt(a) stays ~1.18 ms on a pixel.
    v = terminal_velocity(3.5e-3, model="sqrt")
    assert 4 * 3.5e-3 / v == pytest.approx(1.18e-3, rel=0.01)
    assert exposure_beta(3.5e-3, v, 1 / 30) == pytest.approx(0.0354, rel=0.01)


@pytest.mark.parametrize(
    ("d_mm", "v_m_s"), [(0.5, 2.06), (1.0, 4.03), (2.0, 6.49), (3.0, 8.06), (4.0, 8.83), (5.0, 9.09)]
)
def test_terminal_velocity_matches_gunn_and_kinzer(d_mm, v_m_s):
    assert terminal_velocity(d_mm * 5e-4) == pytest.approx(v_m_s, rel=0.03)


def test_marshall_palmer_extinction_against_a_numerical_integral():
    for rate in (1.0, 10.0, 100.0):
        # sigma = 2 * integral of pi a^2 N(D) dD (geometric optics), D in mm -> m^2.
        num, _ = integrate.quad(lambda d, rate=rate: 2 * math.pi * (d / 2e3) ** 2 * marshall_palmer(d, rate), 0, 20)
        assert rain_extinction(rate) == pytest.approx(num, rel=1e-3)
    assert marshall_palmer(0.0, 5.0) == pytest.approx(8000.0)
    # Visibility 3.912/sigma: a few km in moderate rain, under a km in violent rain.
    assert 2000 < 3.912 / rain_extinction(10.0) < 3000
    assert 400 < 3.912 / rain_extinction(100.0) < 800


def test_wet_albedo_follows_lekner_and_dorf_by_hand():
    r_e, n = 0.066, 1.333
    r_i = 1 - (1 - r_e) / n**2
    assert wet_albedo(0.1, 1.0) == pytest.approx((1 - r_e) * (1 - r_i) * 0.1 / (1 - r_i * 0.1))
    assert wet_albedo(0.1, 1.0) == pytest.approx(0.052, abs=0.002)  # asphalt: about half
    a = np.linspace(0, 1, 11)
    assert (wet_albedo(a, 1.0) <= a + 1e-12).all()
    assert wet_albedo(0.3, 0.0) == 0.3


def _wet(scene, wetness, film):
    w = make_weather("rain", severity=0.5, params={"rain": RainParams(rate_mm_h=0.0, wetness=wetness, water_film=film)})
    w.reset(0, world=scene.world)
    out, _ = w.apply(scene.frame.rgb, scene.ctx())
    return srgb_to_linear(out).mean(axis=2)


def test_a_soaked_road_is_darker(scene):
    asphalt = scene.frame.material == ASPHALT
    before = srgb_to_linear(scene.frame.rgb).mean(axis=2)
    after = _wet(scene, 1.0, 0.0)
    ratio = after[asphalt] / before[asphalt]
    # Compare in 8-bit codes: on dark asphalt one code step is a few % of the value.
    encode = lambda lin: linear_to_srgb(np.repeat(lin[..., None], 3, axis=-1)).astype(int)[..., 0]  # noqa: E731
    expected = encode(wet_albedo(before[asphalt], 1.0)[None, :].astype(np.float32))
    actual = encode(after[asphalt][None, :])
    assert np.abs(actual - expected).max() <= 1
    assert ratio.max() < 0.65


def test_a_water_film_mirrors_the_sky_with_fresnel_reflectance(scene):
    fresnel = view_geometry(scene.camera).fresnel_water
    asphalt = scene.frame.material == ASPHALT
    soaked, film = _wet(scene, 1.0, 0.0), _wet(scene, 1.0, 1.0)
    added = film - soaked  # the mirror term alone
    steep, grazing = asphalt & (fresnel < 0.1), asphalt & (fresnel > 0.4)
    assert steep.sum() > 500 and grazing.sum() > 500
    assert added[grazing].mean() > 3 * added[steep].mean() > 0
    sky = srgb_to_linear(scene.frame.rgb)[scene.frame.material == 5].mean()
    assert (added[asphalt] <= fresnel[asphalt] * sky * 1.5 + 1e-3).all()  # a partial mirror of the sky


def _streak_only(exposure_s: float) -> RainParams:
    return RainParams(rate_mm_h=100.0, wind_m_s=3.0, wetness=0.0, water_film=0.0, haze_scale=0.0, exposure_s=exposure_s)


def _iou(a, b):
    return (a & b).sum() / max((a | b).sum(), 1)


def test_consecutive_drop_masks_overlap_partly(scene):
    """Drops move between frames instead of being redrawn: masks of consecutive
    frames overlap when the drops moved a fraction of their streak, and two
    independent draws do not."""
    masks = {}
    for seed in (0, 1):
        w = make_weather("rain", severity=0.5, params={"rain": _streak_only(1e-3)})
        w.reset(seed, world=scene.world)
        masks[seed] = [w.apply(scene.frame.rgb, scene.ctx(dt=5e-4, time_s=k * 5e-4))[1]["rain"] for k in range(2)]
    assert masks[0][0].sum() > 300
    consecutive = _iou(*masks[0])
    assert 0.2 < consecutive < 0.95
    assert _iou(masks[0][1], masks[1][1]) < consecutive / 5


def test_drops_move_by_their_velocity_relative_to_the_car(scene):
    m = RainModel(_streak_only(1 / 500))
    m.reset(0, world=scene.world)
    m.apply(scene.frame.rgb, scene.ctx())
    f = m.field
    before = f.pos.copy()
    dt, speed = 1 / 15, 5.0
    m.apply(scene.frame.rgb, scene.ctx(dt=dt, ego_speed=speed))
    wind = wind_in_ego(3.0, 90.0, scene.pose[2])
    expected = before + dt * np.column_stack([np.full(len(f), wind[0] - speed), np.full(len(f), wind[1]), f.fall_m_s])
    stayed = np.all((expected >= f.lo) & (expected < f.lo + f.size), axis=1)
    assert stayed.mean() > 0.3  # many drops did not wrap round their box
    np.testing.assert_allclose(f.pos[stayed], expected[stayed], atol=1e-9)
    # Wrapped drops re-enter their box: the field keeps its density.
    assert np.all((f.pos >= f.lo - 1e-9) & (f.pos <= f.lo + f.size + 1e-9))


def test_streaks_fall_down_the_image_when_the_car_is_parked(scene):
    m = RainModel(RainParams(rate_mm_h=50.0, wind_m_s=0.0, exposure_s=1 / 30))
    m.reset(0)
    m.apply(scene.frame.rgb, scene.ctx(ego_speed=0.0))
    u0, v0, u1, v1, _, _ = pt.streaks(
        m.field,
        view_geometry(scene.camera),
        wind_ego=np.zeros(2),
        speed=0.0,
        yaw_rate=0.0,
        exposure_s=1 / 30,
        time_s=0.0,
    )
    assert np.median(v1 - v0) > 3 * np.median(np.abs(u1 - u0))  # start above, end below


def test_drop_sizes_follow_marshall_palmer(scene):
    m = RainModel(RainParams(rate_mm_h=5.0, max_particles=200000))
    m.reset(0)
    m.apply(scene.frame.rgb, scene.ctx())
    d = 2e3 * m.field.radius_m
    assert 0.5 <= d.min() and d.max() <= 7.0
    assert (m.field.fall_m_s > 1.5).all()
