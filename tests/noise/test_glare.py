"""Glare: the specular lobe, its dependence on heading against a low sun, saturation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.camera import SKY, PinholeCamera
from simroad.core.radiometry import srgb_to_linear
from simroad.noise import GlareParams, make_weather
from simroad.noise._geometry import sun_direction_ego, view_geometry
from simroad.noise.glare import air_mass, specular_lobe, sun_colour

LOW_SUN = GlareParams(sun_azimuth_deg=0.0, sun_elevation_deg=5.0, wetness=0.3, veil_coeff=2.0)


def _glare_at(scene, heading_deg: float, params: GlareParams = LOW_SUN, *, sky: bool = False):
    """The clean and glared frames; with ``sky=False`` the sky pixels are set equal in
    both (the sun also clears the sky: tested on its own)."""
    renderer, cam = scene.renderer()
    frame = renderer.render((70.0, 2.0, math.radians(heading_deg)), [])
    w = make_weather("glare", severity=0.5, params={"glare": params})
    w.reset(0, world=scene.world)
    out, _ = w.apply(frame.rgb, scene.ctx(camera=cam, depth=frame.depth, material=frame.material, vehicles=()))
    if not sky:
        out = np.where((frame.material == SKY)[..., None], frame.rgb, out)
    return frame.rgb, out


def test_glare_grows_as_the_heading_turns_towards_a_low_sun_and_saturates(scene):
    headings = (120.0, 60.0, 45.0, 35.0, 20.0, 0.0)  # the sun enters the 70° view at 35°
    added, saturated = [], []
    for heading in headings:
        clean, out = _glare_at(scene, heading)
        added.append((srgb_to_linear(out) - srgb_to_linear(clean)).mean())
        # pixels driven to white from well below it (the overcast sky itself is near white)
        saturated.append(((out == 255).all(axis=2) & (clean.max(axis=2) < 200)).sum())
    assert added[0] == 0.0  # the sun behind the lens plane and its lobe out of view
    assert all(b > 1.3 * a for a, b in zip(added[1:4], added[2:5])), added  # grows as it nears the view
    assert added[-1] > 0.85 * max(added)  # and stays at its maximum (clipping) facing the sun
    assert saturated[-1] > 300 and saturated[2] == 0


def test_the_sky_clears_when_the_sun_comes_out(scene):
    # The world's sky is overcast (near-neutral); under glare's sun it turns clear:
    # bluer away from the sun (behind the car), whiter towards it.
    clean, away = _glare_at(scene, 180.0, sky=True)
    _, towards = _glare_at(scene, 0.0, sky=True)
    renderer, _ = scene.renderer()
    sky = renderer.render((70.0, 2.0, math.pi), []).material == SKY
    top = sky & (np.arange(sky.shape[0]) < sky.shape[0] // 6)[:, None]

    def blueness(img):
        px = img[top].astype(float)
        return float((px[:, 2] - px[:, 0]).mean())

    assert blueness(away) > blueness(clean) + 20
    assert blueness(away) > blueness(towards)


def test_glare_is_symmetric_in_the_heading_offset(scene):
    left = _glare_at(scene, 25.0)
    right = _glare_at(scene, -25.0)
    gain = [(srgb_to_linear(o) - srgb_to_linear(c)).mean() for c, o in (left, right)]
    assert gain[0] == pytest.approx(gain[1], rel=0.25)


def test_specular_lobe_peaks_where_the_view_mirrors_the_sun():
    geom = view_geometry(PinholeCamera())
    rx, ry, rz = (p[:, 160] for p in geom.ray_planes)  # the centre column
    ground = geom.ground[:, 160]
    for elev_deg in (4.0, 8.0, 15.0):
        sun = sun_direction_ego(0.0, math.radians(elev_deg), 0.0)
        # A near-mirror (m = 0.01): Torrance-Sparrow's off-specular shift towards
        # grazing, about 2·m²·cot(e) rad, stays below 0.2°.
        lobe = np.where(ground, specular_lobe(rx, ry, rz, sun, roughness=0.01, f0=0.02), 0.0)
        row = int(np.argmax(lobe))
        depression = math.degrees(math.asin(rz[row]))
        assert depression == pytest.approx(elev_deg, abs=0.5)


def test_a_rough_surface_spreads_the_lobe():
    geom = view_geometry(PinholeCamera())
    rx, ry, rz = (p[geom.ground] for p in geom.ray_planes)
    sun = sun_direction_ego(0.0, math.radians(8.0), 0.0)
    smooth = specular_lobe(rx, ry, rz, sun, roughness=0.05, f0=0.02)
    rough = specular_lobe(rx, ry, rz, sun, roughness=0.4, f0=0.02)
    assert smooth.max() > 10 * rough.max()
    assert (rough > 0.1 * rough.max()).mean() > 3 * (smooth > 0.1 * smooth.max()).mean()


def test_sun_colour_reddens_towards_the_horizon():
    high, low = sun_colour(math.radians(60.0)), sun_colour(math.radians(3.0))
    assert high.min() > 0.8  # nearly white
    assert low[0] == 1.0 and low[2] < 0.3 * low[0]
    assert air_mass(math.radians(90.0)) == pytest.approx(1.0, abs=1e-3)
    assert 10 < air_mass(math.radians(5.0)) < 11.5  # Kasten & Young


def test_no_veil_when_the_sun_is_behind(scene):
    clean, out = _glare_at(scene, 180.0, GlareParams(sun_azimuth_deg=0.0, sun_elevation_deg=20.0, wetness=0.0))
    assert np.abs(out.astype(int) - clean).max() < 8


def test_fog_hides_the_sun(scene):
    base = {"glare": LOW_SUN}
    clean = scene.frame.rgb
    gains = []
    for spec in ("glare", "glare+fog"):
        w = make_weather(spec, severity=0.9, params=base)
        w.reset(0, world=scene.world)
        _out, masks = w.apply(clean, scene.ctx())
        gains.append(masks["glare"].mean())
    assert gains[1] < 0.05 * gains[0]
