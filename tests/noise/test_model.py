"""The model interface: one result convention, keyword-only severity, limits declared once."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.noise import (
    MODELS,
    Limit,
    NoiseModel,
    Params,
    RainParams,
    ShadowParams,
    Weather,
    apply_noise,
    check_noise_params,
    make_weather,
)
from simroad.noise.rain import MP_N0, marshall_palmer, marshall_palmer_slope, rain_extinction

SINGLE = tuple(MODELS)
PARAMS = [MODELS[n].params_type for n in SINGLE]


def test_severity_is_keyword_only_everywhere():
    with pytest.raises(TypeError):
        make_weather("rain", 0.5)
    with pytest.raises(TypeError):
        Weather(("rain",), 0.5)
    with pytest.raises(TypeError):
        apply_noise(np.zeros((32, 32, 3), np.uint8), "rain", 0.5, rng=0)
    assert make_weather("rain", severity=0.25).severity == 0.25


@pytest.mark.parametrize("name", SINGLE)
def test_model_apply_and_weather_apply_return_the_same_result(name, scene):
    model = MODELS[name].from_severity(0.8)
    model.reset(np.random.default_rng(4), world=scene.world)
    weather = make_weather(name, severity=0.8, windscreen=False)  # the model alone, without the glass
    weather.reset(np.random.default_rng(4), world=scene.world)
    out_m, masks_m = model.apply(scene.frame.rgb, scene.ctx())
    out_w, masks_w = weather.apply(scene.frame.rgb, scene.ctx())
    assert isinstance(model, NoiseModel)
    np.testing.assert_array_equal(out_m, out_w)
    assert isinstance(masks_m, dict) and set(masks_m) == set(masks_w) == {name}
    assert masks_m[name].dtype == bool and masks_m[name].shape == scene.frame.rgb.shape[:2]
    np.testing.assert_array_equal(masks_m[name], masks_w[name])


@pytest.mark.parametrize("cls", PARAMS)
def test_every_numeric_field_has_its_limit_declared_once(cls):
    names = {f.name: f.type for f in dataclasses.fields(cls)}
    assert set(cls.LIMITS) <= set(names), "a limit names no field"
    for name, typ in names.items():
        if typ != "bool":
            assert name in cls.LIMITS, f"{cls.__name__}.{name} has no limit"
    for name, limit in cls.LIMITS.items():
        assert limit.describe() in cls.__doc__, f"{name}'s range is missing from the docstring"


@pytest.mark.parametrize("cls", PARAMS)
def test_limits_are_enforced_at_their_bounds(cls):
    default = cls()
    for name, limit in cls.LIMITS.items():
        if limit.length is not None:
            bad: object = (limit.high + 1.0,) * limit.length
            ok: object = (limit.high,) * limit.length
        elif limit.integer:
            bad, ok = int(limit.high) + 1, int(limit.high)
        else:
            bad, ok = limit.high * 1.01 + 1.0, limit.high
        with pytest.raises(SimroadError, match=name.replace("[", r"\[")):
            dataclasses.replace(default, **{name: bad})
        assert dataclasses.replace(default, **{name: ok}) is not None
        low = limit.low if limit.low_inclusive else math.nextafter(limit.low, math.inf)
        if limit.length is None:
            dataclasses.replace(default, **{name: int(low) if limit.integer else low})
            if not limit.low_inclusive:
                with pytest.raises(SimroadError, match=name):
                    dataclasses.replace(default, **{name: limit.low})


def test_limit_describes_itself():
    assert Limit(0.0, 0.1, "s", low_inclusive=False).describe() == "(0, 0.1] s"
    assert Limit(0, 200000, integer=True).describe() == "integer in [0, 200000]"
    assert Limit(-360, 360, "degrees", optional=True).describe() == "[-360, 360] degrees, or None"
    assert Limit(0.5, 50, length=3).describe() == "3 values, each in [0.5, 50]"


def test_optional_and_tuple_limits():
    assert ShadowParams(sun_azimuth_deg=None).sun_azimuth_deg is None
    assert ShadowParams(sun_sky_ratio_rgb=[4, 3, 2]).sun_sky_ratio_rgb == (4.0, 3.0, 2.0)
    with pytest.raises(SimroadError, match=r"sun_sky_ratio_rgb: expected 3 values, got 2"):
        ShadowParams(sun_sky_ratio_rgb=(4.0, 3.0))
    with pytest.raises(SimroadError, match=r"sun_sky_ratio_rgb\[1\]"):
        ShadowParams(sun_sky_ratio_rgb=(4.0, -0.1, 2.0))
    assert ShadowParams(ego_shadow=0).ego_shadow is False


def test_base_params_has_no_limits():
    assert Params.LIMITS == {}


@pytest.mark.parametrize(
    ("params", "names", "match"),
    [
        ({"hail": RainParams()}, None, r"params key: unknown value 'hail'"),
        ({"snow": RainParams()}, None, r"params\['snow'\]: expected a SnowParams, got RainParams"),
        ({"snow": MODELS["snow"].params_type()}, ("rain",), r"params key: unknown value 'snow'"),
        ({"rain": RainParams()}, (), r"none: the weather is 'clear'"),
        ("rain", None, r"params: expected a dict"),
    ],
)
def test_noise_params_are_checked(params, names, match):
    with pytest.raises(SimroadError, match=match):
        check_noise_params(params, names)


def test_noise_params_pass_through():
    p = {"rain": RainParams(rate_mm_h=3.0)}
    assert check_noise_params(p) == p and check_noise_params(None) == {}


def test_marshall_palmer_slope_is_the_one_formula():
    assert marshall_palmer_slope(1.0) == pytest.approx(4.1)
    lam = marshall_palmer_slope(25.0)
    assert lam == pytest.approx(4.1 * 25.0**-0.21)
    assert marshall_palmer(np.array([0.0]), 25.0)[0] == pytest.approx(MP_N0)
    assert marshall_palmer(np.array([1.0]), 25.0)[0] == pytest.approx(MP_N0 * math.exp(-lam))
    assert rain_extinction(25.0) == pytest.approx(math.pi * MP_N0 / lam**3 * 1e-6)
