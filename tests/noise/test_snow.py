"""Snow: flake physics, coherent flakes, snow settling beside the road only."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.camera import ASPHALT, MARKING, ROADSIDE, SHOULDER
from simroad.noise import SnowModel, SnowParams, make_weather
from simroad.noise.rain import exposure_beta, terminal_velocity
from simroad.noise.snow import flake_beta, flake_fall_speed, snow_extinction


def test_flake_beta_is_several_times_a_raindrops_at_thirty_hz():
    a = np.linspace(0.25e-3, 3.5e-3, 200)
    rain_max = exposure_beta(a, terminal_velocity(a), 1 / 30).max()
    flake = flake_beta(5.0, 1.0, 1 / 30)  # a 5 mm flake at 1 m/s: tau = 4a/v = 10 ms
    assert flake == pytest.approx(0.3)
    assert flake > 5 * rain_max
    d = np.linspace(1, 5, 50)
    beta = flake_beta(d, flake_fall_speed(d), 1 / 30)
    assert (beta[d >= 2.5] > 3 * rain_max).all()
    # Same size, same exposure: a flake falls 5-10x slower than a drop, so its beta is larger by as much.
    drop = exposure_beta(d * 5e-4, terminal_velocity(d * 5e-4), 1 / 30)
    assert (beta > 4 * drop).all()


def test_flake_speeds_and_sizes_are_in_the_documented_ranges(scene):
    v = flake_fall_speed(np.linspace(1, 5, 9))
    assert ((0.5 <= v) & (v <= 2.0)).all()
    assert v[-1] == pytest.approx(0.8 * 5**0.16)
    m = SnowModel(SnowParams(flake_density_m3=500.0, max_particles=200000))
    m.reset(0)
    m.apply(scene.frame.rgb, scene.ctx())
    d = 2e3 * m.field.radius_m
    assert 1.0 <= d.min() and d.max() <= 5.0
    assert 0.5 <= m.field.fall_m_s.min() and m.field.fall_m_s.max() <= 2.0
    assert m.field.drift_amp.max() > 0  # flakes flutter


def test_snow_haze_visibility_is_hundreds_of_metres_in_heavy_snow():
    assert 300 < 3.912 / snow_extinction(1000.0) < 800
    assert snow_extinction(3000.0) == pytest.approx(3 * snow_extinction(1000.0))


def _settled(scene, on_road: bool):
    p = SnowParams(flake_density_m3=0.0, settle=0.9, settle_on_road=on_road, haze_scale=0.0)
    w = make_weather("snow", severity=0.5, params={"snow": p})
    w.reset(0, world=scene.world)
    return w.apply(scene.frame.rgb, scene.ctx())[1]["snow"]


def test_snow_settles_on_the_roadside_and_shoulders_not_the_road(scene):
    mat = scene.frame.material
    mask = _settled(scene, on_road=False)
    side = np.isin(mat, [ROADSIDE, SHOULDER])
    assert mask[side].mean() > 0.5
    assert not mask[np.isin(mat, [ASPHALT, MARKING])].any()
    assert _settled(scene, on_road=True)[mat == ASPHALT].mean() > 0.5


def test_consecutive_flake_masks_overlap_partly(scene):
    p = SnowParams(flake_density_m3=2000.0, haze_scale=0.0, exposure_s=1 / 60)
    masks = {}
    for seed in (0, 1):
        w = make_weather("snow", severity=0.5, params={"snow": p})
        w.reset(seed, world=scene.world)
        masks[seed] = [w.apply(scene.frame.rgb, scene.ctx(dt=5e-3, time_s=k * 5e-3))[1]["snow"] for k in range(2)]

    def iou(a, b):
        return (a & b).sum() / (a | b).sum()

    assert masks[0][0].sum() > 300
    assert 0.2 < iou(*masks[0]) < 0.95
    assert iou(masks[0][1], masks[1][1]) < iou(*masks[0]) / 5
