"""The sky clears when the sun comes out, from the same sun as the shadows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.camera.codes import SKY
from simroad.camera.sky import sky_radiance
from simroad.core.radiometry import srgb_to_linear
from simroad.noise import ShadowParams, make_weather
from simroad.noise._sunny_sky import clear_sky, clear_sky_panorama
from simroad.noise.context import FrameState


def _state(scene) -> FrameState:
    ctx = scene.ctx()
    rgb = scene.frame.rgb
    ground = scene.frame.material != SKY
    return FrameState(srgb_to_linear(rgb), scene.camera, scene.frame.depth, scene.frame.material, ground, ctx)


def test_panorama_is_the_cie_clear_sky_in_world_directions():
    pano = clear_sky_panorama(30.0, 20.0)
    # Row i at elevation -2 + 0.5 i, column j at azimuth 0.5 j (degrees).
    for el, az in [(10.0, 30.0), (45.0, 210.0), (5.0, 120.0)]:
        e, a = math.radians(el), math.radians(az)
        d = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        ref = sky_radiance(d, sun_azimuth=30.0, sun_elevation=20.0, condition="clear")
        np.testing.assert_allclose(pano[int((el + 2) / 0.5), int(az / 0.5)], ref, rtol=1e-5)
    # Brighter towards the sun than away from it at the same elevation; bluer away.
    toward, away = pano[int(22 / 0.5), int(30 / 0.5)], pano[int(22 / 0.5), int(210 / 0.5)]
    assert toward.sum() > 2 * away.sum()
    assert away[2] / away[0] > toward[2] / toward[0]


def test_weight_zero_changes_nothing_and_one_gives_the_clear_sky(scene):
    st = _state(scene)
    before = st.lin.copy()
    clear_sky(st, (math.radians(30.0), math.radians(20.0)), 0.0)
    np.testing.assert_array_equal(st.lin, before)
    assert st.unmasked is None

    st = _state(scene)
    clear_sky(st, (math.radians(30.0), math.radians(20.0)), 1.0)
    sky = scene.frame.material == SKY
    np.testing.assert_array_equal(st.lin[~sky], before[~sky])  # only the sky changes
    assert st.unmasked is not None and (st.unmasked == sky).all()
    # A sky pixel takes the clear sky of its own direction (the camera's heading counts).
    from simroad.camera.sky import camera_directions

    rows, cols = np.nonzero(sky)
    k = len(rows) // 2
    d = camera_directions(scene.camera)[rows[k], cols[k]]
    ref = sky_radiance(d, sun_azimuth=30.0, sun_elevation=20.0, condition="clear")
    np.testing.assert_allclose(st.lin[rows[k], cols[k]], ref, rtol=0.03)


def test_two_models_sharing_the_sun_clear_the_sky_once(scene):
    sun = (math.radians(30.0), math.radians(20.0))
    once = _state(scene)
    clear_sky(once, sun, 0.6)
    twice = _state(scene)
    clear_sky(twice, sun, 0.6)
    clear_sky(twice, sun, 0.6)  # the second model: nothing more
    np.testing.assert_allclose(twice.lin, once.lin, rtol=1e-6)
    more = _state(scene)
    clear_sky(more, sun, 0.3)
    clear_sky(more, sun, 0.6)  # the larger weight wins
    np.testing.assert_allclose(more.lin, once.lin, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("severity", [0.3, 0.9])
def test_shadow_noise_turns_the_sky_blue_but_keeps_it_out_of_its_mask(scene, severity):
    w = make_weather("shadow", severity=severity, params={"shadow": ShadowParams.from_severity(severity)})
    w.reset(0, world=scene.world)
    out, masks = w.apply(scene.frame.rgb, scene.ctx())
    sky = scene.frame.material == SKY
    blue = lambda img: float((img[sky][:, 2].astype(float) - img[sky][:, 0]).mean())  # noqa: E731
    assert blue(out) > blue(scene.frame.rgb) + 10 * severity
    assert not masks["shadow"][sky].any()
