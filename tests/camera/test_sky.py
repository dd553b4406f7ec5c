"""The CIE sky: hand-worked luminance ratios, colour trends, scaling, reproducible draws."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.camera import PinholeCamera
from simroad.camera.geometry import CameraConfig
from simroad.camera.lighting import NOMINAL_EXPOSURE
from simroad.camera.sky import (
    CIE_SKY_TYPES,
    SkySpec,
    Sun,
    _diffuse_integral,
    cie_relative_luminance,
    draw_sky,
    sky_image,
    sky_radiance,
)
from simroad.errors import SimroadError


def _dir(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def test_overcast_type_1_is_moon_spencer_three_to_one():
    """CIE type 1: L(Z) / L_z = (1 + 4 exp(-0.7 / cos Z)) / (1 + 4 exp(-0.7)); at the
    horizon 1 / (1 + 4 e^-0.7) = 0.3349, the 1:3 of Moon & Spencer's overcast sky."""
    horizon = cie_relative_luminance(np.array(math.pi / 2), np.array(1.0), 0.5, 1)
    assert float(horizon) == pytest.approx(1 / (1 + 4 * math.exp(-0.7)), rel=1e-9)
    assert float(horizon) == pytest.approx(1 / 3, abs=0.002)
    z = math.radians(60)
    mid = cie_relative_luminance(np.array(z), np.array(2.0), 0.3, 1)
    assert float(mid) == pytest.approx((1 + 4 * math.exp(-0.7 / 0.5)) / (1 + 4 * math.exp(-0.7)))


def test_overcast_is_independent_of_the_sun_and_clear_peaks_at_the_sun():
    zen = np.full(360, math.radians(50))
    chi_dirs = np.radians(np.arange(360) / 2.0)
    over = cie_relative_luminance(zen, chi_dirs, math.radians(50), 1)
    assert np.ptp(over) < 1e-12
    clear = cie_relative_luminance(zen, chi_dirs, math.radians(50), 12)
    assert np.argmax(clear) == 0  # chi = 0: the sun's direction
    assert clear[0] > 5 * clear[180]  # circumsolar region far brighter than 90 deg away


def test_zenith_is_one_and_types_table_is_complete():
    assert sorted(CIE_SKY_TYPES) == list(range(1, 16))
    for t in CIE_SKY_TYPES:
        sz = math.radians(40)
        assert float(cie_relative_luminance(np.array(0.0), np.array(sz), sz, t)) == pytest.approx(1.0)


def test_overcast_diffuse_integral_is_seven_ninths_pi():
    """Integral of (1 + 2 cos Z)/3-like gradation: for Moon & Spencer exactly 7 pi / 9;
    CIE type 1 is its close fit (within 2 %)."""
    assert _diffuse_integral(0.5, 1) == pytest.approx(7 * math.pi / 9, rel=0.02)


def test_white_surface_scaling_under_overcast():
    """A white horizontal surface = NOMINAL_EXPOSURE: its radiance pi * L_sky integral / pi."""
    n = 60
    el = (np.arange(n) + 0.5) * 90.0 / n
    az = (np.arange(2 * n) + 0.5) * 180.0 / n
    E, A = np.meshgrid(el, az, indexing="ij")
    d = np.stack([np.cos(np.radians(E)) * np.cos(np.radians(A)), np.cos(np.radians(E)) * np.sin(np.radians(A))], -1)
    dirs = np.concatenate([d, np.sin(np.radians(E))[..., None]], -1)
    L = sky_radiance(dirs, sun_azimuth=30.0, sun_elevation=40.0, condition="overcast")
    Y = L @ np.array([0.2126, 0.7152, 0.0722])
    dw = np.cos(np.radians(E)) * math.radians(90.0 / n) * math.radians(180.0 / n)
    white = float((Y * np.sin(np.radians(E)) * dw).sum()) / math.pi
    assert white == pytest.approx(NOMINAL_EXPOSURE, rel=0.03)


def test_clear_zenith_is_bluer_than_horizon_and_overcast_is_neutral():
    dirs = np.array([_dir(180.0, 89.0), _dir(180.0, 1.0)])
    clear = sky_radiance(dirs, sun_azimuth=0.0, sun_elevation=30.0, condition="clear")
    zen_b, hor_b = clear[0, 2] / clear[0, 0], clear[1, 2] / clear[1, 0]
    assert zen_b > 2.0 * hor_b and hor_b < 1.5
    over = sky_radiance(dirs, sun_azimuth=0.0, sun_elevation=30.0, condition="overcast")
    assert np.all(np.abs(over / over[:, 1:2] - 1.0) < 0.1)
    assert over[0, 1] == pytest.approx(3.0 * over[1, 1], rel=0.05)  # 3:1 zenith to horizon


def test_sky_image_and_draws_are_reproducible_and_validated():
    cam = PinholeCamera(CameraConfig(width=64, height=36))
    a = sky_image(cam, draw_sky(np.random.default_rng(4)), heading=0.0)
    b = sky_image(cam, draw_sky(np.random.default_rng(4)), heading=0.0)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (36, 64, 3) and a.dtype == np.float32 and a.min() >= 0 and a.max() <= 255
    draws = [draw_sky(np.random.default_rng(s)) for s in range(1000)]
    share = {c: sum(d.condition == c for d in draws) / len(draws) for c in ("overcast", "hazy", "clear")}
    # The default profile's shares: overcast 0.5, hazy 0.25, the rest (0.25) sunny.
    assert share == pytest.approx({"overcast": 0.5, "hazy": 0.25, "clear": 0.25}, abs=0.05)
    assert all(5.0 <= d.sun.elevation_deg <= 65.0 and 4000.0 <= d.illuminant_k <= 7500.0 for d in draws)
    overcast = [d.illuminant_k for d in draws if d.condition == "overcast"]
    low_sun = [d.illuminant_k for d in draws if d.condition == "clear" and d.sun.elevation_deg < 10.0]
    assert min(overcast) >= 6300.0 and (not low_sun or max(low_sun) < 5500.0)  # overcast cool, a low sun warm
    with pytest.raises(SimroadError, match="condition"):
        sky_radiance(np.ones((1, 3)), sun_azimuth=0, sun_elevation=30, condition="sunny")
    with pytest.raises(SimroadError, match="elevation"):
        Sun(0.0, 95.0)
    with pytest.raises(SimroadError, match="brightness"):
        SkySpec("clear", Sun(0.0, 30.0), brightness=-1.0)


def test_sky_image_takes_a_condition_and_a_sun_and_clear_is_bluer_than_overcast():
    cam = PinholeCamera(CameraConfig(width=64, height=36))
    sun = Sun(180.0, 35.0)  # behind the camera at heading 0
    clear = sky_image(cam, "clear", sun, heading=0.0)
    over = sky_image(cam, "overcast", sun, heading=0.0)
    top = (slice(0, 5), slice(None))
    assert (clear[top][..., 2] - clear[top][..., 0]).mean() > 40  # blue sky
    assert abs((over[top][..., 2] - over[top][..., 0]).mean()) < 15  # neutral
    with pytest.raises(SimroadError, match="sun"):
        sky_image(cam, "clear")
