"""Drops on the windscreen and the wiper: optics worked by hand, drops that stay put
until the wiper passes (on frames rendered by RoadCamEnv), density against rain rate,
bit-identical frames without rain, determinism, and bad input refused by name."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.control import autopilot_action
from simroad.core.radiometry import MASK_THRESHOLD, change_mask, srgb_to_linear
from simroad.envs import RoadCamConfig, RoadCamEnv
from simroad.noise import WindscreenModel, WindscreenParams, make_weather
from simroad.noise._drops import draw_drops, draw_drops_reference
from simroad.noise._glass import cap_deflection, cap_transmittance, contact_radius, defocus_diameter_m, glass_view
from simroad.noise._windscreen_params import collection_rate, slide_velocity
from simroad.noise._wiper import blade_angle, swept_interval

OFF = WindscreenParams(wiper_period_s="off")


# -- optics and geometry, by hand ----------------------------------------------------


def test_defocus_blur_of_the_glass_by_hand():
    # A 4 mm f/2 lens (aperture 2 mm) focused at infinity sees a point 10 cm away as a
    # disc of A·f/(z − f) = 2·4/96 mm = 83.3 µm on the sensor.
    assert defocus_diameter_m(4e-3, 2e-3, 0.1, math.inf) == pytest.approx(8.333e-5, rel=1e-3)
    # Focused at 10 m: A·f·(S − z)/(z·(S − f)) = 2·4·9900/(100·9996) µm·1000 = 79.2 µm.
    assert defocus_diameter_m(4e-3, 2e-3, 0.1, 10.0) == pytest.approx(7.923e-5, rel=1e-3)
    # In pixels of the default 320-px camera (fx = 160/tan 35° = 228.5 px, pitch f/fx):
    fx = 160 / math.tan(math.radians(35))
    assert defocus_diameter_m(4e-3, 2e-3, 0.1, 10.0) / (4e-3 / fx) == pytest.approx(4.53, abs=0.01)


def test_the_glass_view_on_the_optical_axis_by_hand(scene):
    p = WindscreenParams()
    view = glass_view(scene.camera, p.glass)
    cam = scene.camera.config
    gx, gy, dist = view.pixel_to_glass(np.array([(cam.width - 1) / 2]), np.array([(cam.height - 1) / 2]))
    assert dist[0] == pytest.approx(p.glass_distance_m) and abs(gx[0]) < 1e-12 and abs(gy[0]) < 1e-12
    # The axis meets the glass at cos(tilt + pitch) to its normal; its blur is the thin-lens disc.
    u, v = round((cam.width - 1) / 2), round((cam.height - 1) / 2)
    assert view.cos_inc[v, u] == pytest.approx(math.cos(math.radians(p.glass_tilt_deg + cam.pitch_deg)), abs=0.01)
    c_px = defocus_diameter_m(4e-3, 2e-3, 0.1, 10.0) / (4e-3 / view.fx)
    assert view.blur[v, u] == pytest.approx(c_px, rel=0.02)
    # The glass leans back: rows below the axis see it farther away, more obliquely.
    assert view.dist[-1].min() > 2 * p.glass_distance_m > view.dist[0].max()
    # Glass -> image -> glass is the identity.
    gx, gy = np.array([-0.05, 0.0, 0.08]), np.array([-0.1, 0.0, 0.02])
    back = view.pixel_to_glass(*view.glass_to_pixel(gx, gy))
    np.testing.assert_allclose(back[0], gx, atol=1e-9)
    np.testing.assert_allclose(back[1], gy, atol=1e-9)


def test_a_drop_is_a_water_lens_by_hand():
    # Contact radius of a cap with a sphere's volume: a = D/2·(4 sin³γ/(2 − 3cos γ + cos³ γ))^(1/3).
    assert contact_radius(1e-3, 60.0) == pytest.approx(0.804e-3, rel=1e-3)
    assert contact_radius(1e-3, 90.0) == pytest.approx(0.5e-3 * 2 ** (1 / 3), rel=1e-6)  # a hemisphere
    # Deflection at the rim of a 60° cap: asin(1.333·0.5·sin 60°) − asin(0.5·sin 60°) at ρ = 0.5.
    s = 0.5 * math.sin(math.radians(60))
    assert cap_deflection(0.5, 60.0) == pytest.approx(math.asin(1.333 * s) - math.asin(s))
    assert cap_deflection(0.0, 60.0) == 0.0
    # Total internal reflection beyond ρ = 1/(n sin γ) = 0.866: no light through.
    assert math.isnan(cap_deflection(0.9, 60.0)) and cap_transmittance(0.9, 60.0) == 0.0
    assert 0.97 < cap_transmittance(0.0, 60.0) < 0.99  # (1 − 0.02) at normal exit
    assert cap_transmittance(1.01, 40.0) == 0.0  # outside the drop


def test_collection_grows_with_rain_rate_and_headwind():
    rates = [collection_rate(r, 15.0) for r in (1.0, 5.0, 25.0, 100.0)]
    assert all(a < b for a, b in zip(rates, rates[1:]))
    still, moving = collection_rate(25.0, 0.0), collection_rate(25.0, 30.0)
    assert moving > 5 * still > 0.0
    # Linear in speed: n·(v·cos φ + w·sin φ).
    mid = collection_rate(25.0, 15.0)
    assert mid == pytest.approx((still + moving) / 2, rel=1e-9)
    assert collection_rate(0.0, 20.0) == 0.0 < collection_rate(0.0, 20.0, flake_density_m3=500.0)


def test_running_drops_by_the_force_balance():
    p = WindscreenParams()
    big, small = np.array([2.4e-3]), np.array([0.5e-3])
    assert slide_velocity(big, 0.0, p)[0] < 0.0  # runs down a still car's glass
    assert slide_velocity(small, 0.0, p)[0] == 0.0  # held by the contact line
    assert slide_velocity(big, 25.0, p)[0] == 0.0  # the airflow about balances gravity at 90 km/h
    assert slide_velocity(big, 40.0, p)[0] > 0.0  # blown up the glass at 144 km/h
    assert slide_velocity(small, 25.0, p)[0] == 0.0


def test_the_wiper_sweeps_out_and_back():
    arc = math.radians(110)
    assert blade_angle(0.0, 0.5, arc) == 0.0
    assert blade_angle(0.5, 0.5, arc) == pytest.approx(arc)
    assert blade_angle(0.25, 0.5, arc) == pytest.approx(arc / 2)
    assert blade_angle(1.2, 0.5, arc) == 0.0  # resting until the next cycle
    assert swept_interval(0.4, 0.6, 0.5, arc) == (pytest.approx(blade_angle(0.4, 0.5, arc)), pytest.approx(arc))
    assert swept_interval(1.0, 1.5, 0.5, arc) is None


# -- the model on rendered frames ------------------------------------------------------


def _windscreen(env: RoadCamEnv) -> WindscreenModel:
    assert env.weather is not None
    model = env.weather.models["windscreen"]
    assert isinstance(model, WindscreenModel)
    return model


def _bank(model: WindscreenModel):
    assert model._view is not None
    return model._bank(model._view)


def _footprint(model: WindscreenModel, keep: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Pixels the sprites of the drops ``keep`` touch."""
    bank = _bank(model)
    out = np.zeros(shape, bool)
    d = model.drops
    for k in np.flatnonzero(keep & (d.sprite >= 0)):
        s = slice(bank.start[d.sprite[k]], bank.start[d.sprite[k]] + bank.length[d.sprite[k]])
        x, y = d.u[k] + bank.arrays["du"][s], d.v[k] + bank.arrays["dv"][s]
        ok = (x >= 0) & (x < shape[1]) & (y >= 0) & (y < shape[0])
        out[y[ok], x[ok]] = True
    return out


def _step(env: RoadCamEnv):
    return env.step(autopilot_action(env.highway_env.road, env.vehicle))


def test_drops_stay_put_between_frames_until_the_wiper_passes():
    env = RoadCamEnv(scenario="racetrack", noise="rain", severity=0.5, windscreen=WindscreenParams(wiper_period_s=2.0))
    _, info = env.reset(seed=3)
    model = _windscreen(env)
    mask, ious, wiped = info["noise_masks"]["windscreen"], [], 0
    for _ in range(12):
        before = dict(zip(model.drops.ident.tolist(), zip(model.drops.u.tolist(), model.drops.v.tolist())))
        _, _, _, _, info = _step(env)
        new = info["noise_masks"]["windscreen"]
        now = list(zip(model.drops.u.tolist(), model.drops.v.tolist()))
        old = np.array([before.get(i) is not None for i in model.drops.ident.tolist()])
        if old.sum() < 0.5 * len(before):  # the wiper passed: every old drop is gone
            assert not old.any()
            wiped += 1
        elif old.sum() > 100:
            # The pixels of the drops that were there and stayed (big drops run down:
            # they are left out), where no other drop reaches.
            still = np.array([before.get(i) == p for i, p in zip(model.drops.ident.tolist(), now)])
            assert still.sum() > 0.9 * old.sum()
            fp = _footprint(model, still, new.shape) & ~_footprint(model, ~still, new.shape)
            a, b = mask & fp, new & fp
            ious.append((a & b).sum() / max((a | b).sum(), 1))
        mask = new
    assert wiped >= 2  # the 2-s wiper passed during the 2.4 s
    assert len(ious) >= 5 and min(ious) >= 0.9, ious
    env.close()


def test_a_wipe_leaves_the_glass_clean_where_it_passed(scene):
    w = make_weather("rain", severity=0.6, windscreen=WindscreenParams(wiper_period_s=3.0))
    w.reset(np.random.default_rng(1), world=scene.world)
    model = w.models["windscreen"]
    assert isinstance(model, WindscreenModel)
    drops, area, blade = [], [], []
    for k in range(4 * 30):  # 4 s at 30 frames/s: at least one cycle
        _, masks = w.apply(scene.frame.rgb, scene.ctx(dt=1 / 30, time_s=k / 30))
        drops.append(set(model.drops.ident.tolist()))
        area.append(float(masks["windscreen"].mean()))
        blade.append(model.blade_visible)
    first = blade.index(True)  # the up-stroke crosses the view
    last = first + 1 + blade[first + 1 :].index(False)
    down = last + blade[last:].index(True)  # and the down-stroke
    after = down + 1 + blade[down + 1 :].index(False)
    before = drops[first - 1]
    assert len(before) > 100 and not before & drops[after]  # every drop there before is gone
    assert area[after] < 0.25 * area[first - 1]  # only the drops that came since
    assert max(area[first:after]) > area[first - 1]  # the blade covers a band while it passes


def test_drop_density_grows_with_rain_rate(scene):
    from simroad.noise import RainParams

    # Averaged over two cycles of a 4-s wiper (with the wiper off the glass saturates
    # within seconds, whatever the rate).
    glass = WindscreenParams(wiper_period_s=4.0, max_drops=20000)
    cover, area = [], []
    for rate in (2.0, 10.0, 40.0):
        w = make_weather("rain", params={"rain": RainParams(rate_mm_h=rate)}, windscreen=glass)
        w.reset(np.random.default_rng(0), world=scene.world)
        model = w.models["windscreen"]
        assert isinstance(model, WindscreenModel)
        c, m = [], []
        for k in range(8 * 15):
            _, masks = w.apply(scene.frame.rgb, scene.ctx(dt=1 / 15, time_s=k / 15))
            c.append(model.coverage)
            m.append(masks["windscreen"].mean())
        cover.append(float(np.mean(c)))
        area.append(float(np.mean(m)))
    assert cover[0] < cover[1] < cover[2] < glass.max_coverage
    assert area[0] < area[1] < area[2]
    assert cover[2] / cover[0] > 5  # 20 times the rain: the drops grow less than the rate (their sizes grow)


def test_snow_melts_into_drops_too(scene):
    w = make_weather("snow", severity=0.6)
    w.reset(np.random.default_rng(0), world=scene.world)
    _, masks = w.apply(scene.frame.rgb, scene.ctx())
    assert masks["windscreen"].any()


def test_every_drop_pixel_it_changed_is_in_its_mask(scene):
    model = WindscreenModel(OFF, rain_rate_mm_h=30.0)
    model.reset(0)
    out, masks = model.apply(scene.frame.rgb, scene.ctx())
    changed = change_mask(scene.frame.rgb, out)
    assert changed.any() and (changed & ~masks["windscreen"]).sum() == 0
    diff = np.abs(out.astype(int) - scene.frame.rgb.astype(int)).max(axis=2)
    assert (diff[~masks["windscreen"]] < MASK_THRESHOLD).all()


def test_the_compiled_pass_matches_its_numpy_reference(scene):
    model = WindscreenModel(OFF, rain_rate_mm_h=50.0)
    model.reset(0)
    model.apply(scene.frame.rgb, scene.ctx())
    bank = _bank(model)
    lin = srgb_to_linear(scene.frame.rgb)
    a, b = lin.copy(), lin.copy()
    covered = draw_drops(a, model.drops, bank, rim=0.3, factor=4)
    draw_drops_reference(b, model.drops, bank, rim=0.3, factor=4)
    assert covered.any() and not np.array_equal(a, lin)
    np.testing.assert_allclose(a, b, atol=2e-6)


@pytest.mark.parametrize("speed", [40.0, 5.0])  # drops run up the glass at 40 m/s; at 5 only big ones run down
def test_the_compiled_motion_and_wipe_match_numpy(scene, speed):
    """advance_drops (one pass) against DropField.move, then the wipe in numpy."""
    import copy

    from simroad.noise._drops_kernel import advance_drops

    model = WindscreenModel(OFF, rain_rate_mm_h=80.0)
    model.reset(0)
    model.apply(scene.frame.rgb, scene.ctx())
    view, p, dt = model._view, model.params, 1 / 15
    velocity = slide_velocity(model.drops.radius, speed, p)
    assert len(model.drops) > 100 and (velocity != 0).any()
    swept = np.array([[0.4, 0.9]])  # the blade between these angles (radians) during the frame
    ref = copy.deepcopy(model.drops)
    ref.move(view, velocity != 0.0, velocity * dt)
    px, py = p.wiper_pivot_m
    hit = (np.hypot(ref.gy - py, ref.gx - px) <= p.wiper_length_m) & (np.arctan2(ref.gy - py, ref.gx - px) >= 0.4)
    ref.keep(~(hit & (np.arctan2(ref.gy - py, ref.gx - px) <= 0.9)))
    d = model.drops
    size = (view.config.width, view.config.height)
    wiper = (px, py, p.wiper_length_m)
    alive = advance_drops(d.gx, d.gy, velocity, d.u, d.v, dt, view.projection(), size, wiper, swept)
    d.keep(alive)
    assert 0 < len(d) < len(alive) - 10  # the blade took some
    np.testing.assert_array_equal(d.ident, ref.ident)
    np.testing.assert_array_equal(d.u, ref.u)
    np.testing.assert_array_equal(d.v, ref.v)
    np.testing.assert_allclose(d.gy, ref.gy, rtol=0, atol=1e-12)


# -- switches, determinism, bad input --------------------------------------------------


def _frames(seed: int, steps: int = 3, **kw) -> list[tuple[np.ndarray, dict]]:
    env = RoadCamEnv(scenario="racetrack", noise="rain", **kw)
    out = [env.reset(seed=seed)]
    out += [_step(env)[::4] for _ in range(steps)]
    env.close()
    return out


def test_same_seed_same_frames_and_masks():
    a, b = _frames(5, severity=0.7), _frames(5, severity=0.7)
    for (fa, ia), (fb, ib) in zip(a, b):
        np.testing.assert_array_equal(fa, fb)
        np.testing.assert_array_equal(ia["noise_masks"]["windscreen"], ib["noise_masks"]["windscreen"])
    c = _frames(6, steps=0, severity=0.7)
    assert not np.array_equal(a[0][0], c[0][0])


def test_severity_zero_and_the_switch():
    clear = _frames(2, steps=2, severity=0.0, windscreen=True)
    env = RoadCamEnv(scenario="racetrack", noise="clear")
    ref = [env.reset(seed=2)] + [_step(env)[::4] for _ in range(2)]
    for (f, info), (g, _) in zip(clear, ref):
        np.testing.assert_array_equal(f, g)  # no rain, no drops: bit-identical
        assert not info["noise_masks"]["windscreen"].any()
    # Without the sensor (whose auto-exposure sees the drops and sets the next frame's
    # motion blur), the rain is the same with and without the glass: the glass draws
    # its randomness after the rain's.
    dry = _frames(2, steps=1, severity=0.7, windscreen=False, camera_effects=False)
    wet = _frames(2, steps=1, severity=0.7, camera_effects=False)
    assert "windscreen" not in dry[0][1]["noise_masks"]
    for (_, di), (_, wi) in zip(dry, wet):
        np.testing.assert_array_equal(di["noise_masks"]["rain"], wi["noise_masks"]["rain"])


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"wiper_period_s": 0.5}, "wiper_period_s"),  # shorter than its two strokes
        ({"wiper_period_s": -1.0}, "wiper_period_s"),
        ({"wiper_period_s": float("nan")}, "wiper_period_s"),
        ({"wiper_period_s": "sometimes"}, "wiper_period_s"),
        ({"wiper_period_s": [1.0]}, "wiper_period_s"),
        ({"wiper_period_s": 500.0}, "wiper_period_s"),
        ({"wiper_stroke_s": 0.0}, "wiper_stroke_s"),
        ({"glass_distance_m": 0.0}, "glass_distance_m"),
        ({"wiper_pivot_m": (0.0,)}, "wiper_pivot_m"),
        ({"max_drops": 1.5}, "max_drops"),
        ({"contact_angle_deg": "wet"}, "contact_angle_deg"),
    ],
)
def test_invalid_windscreen_parameters_are_refused_by_name(kw, name):
    with pytest.raises(SimroadError, match=name):
        WindscreenParams(**kw)


def test_wiper_modes_and_refusals_elsewhere(scene):
    assert WindscreenParams(wiper_period_s="fast").wiper_period_s == 1.0
    assert WindscreenParams(wiper_period_s="off").wiper_period_s is None
    assert WindscreenParams(wiper_period_s=None).wiper_period_s is None
    with pytest.raises(SimroadError, match="Did you mean 'intermittent'"):
        WindscreenParams(wiper_period_s="intermitent")
    with pytest.raises(SimroadError, match="windscreen"):
        make_weather("rain", windscreen="yes")
    with pytest.raises(SimroadError, match="windscreen"):
        RoadCamConfig(noise="rain", windscreen=2)
    with pytest.raises(SimroadError, match="rain_rate_mm_h"):
        WindscreenModel(OFF, rain_rate_mm_h=-1.0)
    steep = WindscreenModel(WindscreenParams(glass_tilt_deg=75.0), rain_rate_mm_h=10.0)
    steep.reset(0)
    with pytest.raises(SimroadError, match="glass_tilt_deg"):
        steep.apply(scene.frame.rgb, scene.ctx(camera=_pitched(scene, 20.0)))
    assert make_weather("glare", windscreen=True).models.keys() == {"glare"}  # no rain, no drops


def _pitched(scene, pitch: float):
    from dataclasses import replace

    from simroad.camera import PinholeCamera

    cam = PinholeCamera(replace(scene.camera.config, pitch_deg=pitch))
    cam.set_pose(*scene.pose)
    return cam
