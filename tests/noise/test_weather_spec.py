"""The spec string, the severity mapping and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.core.radiometry import change_mask, linear_to_srgb, srgb_to_linear
from simroad.noise import (
    FogParams,
    GlareParams,
    NoiseContext,
    RainParams,
    ShadowParams,
    SnowParams,
    Weather,
    apply_noise,
    make_weather,
    parse_noise,
)


@pytest.mark.parametrize(
    ("spec", "names"),
    [
        ("clear", ()),
        ("rain", ("rain",)),
        ("rain+glare", ("rain", "glare")),
        ("glare+rain", ("rain", "glare")),
        ("shadow+snow", ("snow", "shadow")),
        (" Fog + rain ", ("rain", "fog")),
    ],
)
def test_spec_is_parsed_into_canonical_order(spec, names):
    assert parse_noise(spec) == names
    assert make_weather(spec, severity=0.3).spec == ("+".join(names) or "clear")


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("rian", r"noise: unknown value 'rian'.*'rain', 'snow'.*Did you mean 'rain'\?"),
        ("rain+shadw", r"Did you mean 'shadow'\?"),
        ("rain+rain", r"'rain' given more than once"),
        ("clear+fog", r"'clear' cannot be combined"),
        ("rain++fog", r"empty name"),
        ("", r"empty name"),
        (3, r"expected a string"),
    ],
)
def test_bad_specs_are_clear_errors(spec, match):
    with pytest.raises(SimroadError, match=match):
        parse_noise(spec)


@pytest.mark.parametrize("severity", [-0.1, 1.01, math.nan, math.inf, "high", None])
def test_severity_outside_the_unit_interval_is_rejected(severity):
    with pytest.raises(SimroadError, match="severity"):
        make_weather("rain", severity=severity)


@pytest.mark.parametrize("cls", [RainParams, SnowParams, ShadowParams, GlareParams, FogParams])
def test_from_severity_validates_too(cls):
    with pytest.raises(SimroadError, match="severity"):
        cls.from_severity(math.nan)
    assert cls.from_severity(0.0).is_identity
    assert not cls.from_severity(0.5).is_identity


def test_severity_maps_to_documented_parameters():
    assert RainParams.from_severity(0.5).rate_mm_h == pytest.approx(25.0)
    assert RainParams.from_severity(1.0).rate_mm_h == pytest.approx(100.0)
    assert SnowParams.from_severity(1.0).flake_density_m3 == pytest.approx(3000.0)
    assert SnowParams.from_severity(0.5).settle == 0.0 and SnowParams.from_severity(1.0).settle == pytest.approx(0.9)
    assert ShadowParams.from_severity(1.0).sun_elevation_deg == pytest.approx(20.0)
    assert GlareParams.from_severity(1.0).sun_elevation_deg == pytest.approx(5.0)
    assert FogParams.from_severity(1.0).visibility_m == pytest.approx(30.0)
    assert FogParams.from_severity(1.0).beta_ext == pytest.approx(3.912 / 30.0)


def test_params_override_the_severity_mapping():
    w = make_weather("rain+fog", severity=0.2, params={"fog": FogParams(visibility_m=55.0)})
    assert w.models["fog"].params.visibility_m == 55.0
    assert w.models["rain"].params == RainParams.from_severity(0.2)


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"snow": SnowParams()}, r"params key: unknown value 'snow'.*'rain'"),
        ({"rain": FogParams()}, r"params\['rain'\]: expected a RainParams, got FogParams"),
        ([("rain", RainParams())], r"params: expected a dict"),
    ],
)
def test_bad_params_are_clear_errors(params, match):
    with pytest.raises(SimroadError, match=match):
        make_weather("rain", severity=0.5, params=params)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(rate_mm_h=-1.0), "rate_mm_h"),
        (dict(exposure_s=0.0), "exposure_s"),
        (dict(wetness=math.nan), "wetness"),
        (dict(max_particles=1.5), "max_particles"),
    ],
)
def test_params_validate_their_fields(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        RainParams(**kwargs)


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((40, 60, 3), dtype=np.int32), r"image: expected dtype uint8 or float32 or float64, got int32"),
        (np.zeros((40, 60), dtype=np.uint8), r"image: expected an array of shape \(H, W, 3\)"),
        (np.zeros((40, 60, 4), dtype=np.uint8), r"image: expected an array of shape \(H, W, 3\)"),
        (np.full((40, 60, 3), 2.0, dtype=np.float32), r"image: float images must lie in \[0, 1\]"),
        (np.zeros((8, 60, 3), dtype=np.uint8), r"image: expected at least 16x16"),
        ([[1, 2, 3]], r"image: expected a numpy array"),
        (np.zeros((800, 1400, 3), dtype=np.uint8), r"flat-ground default camera supports"),
    ],
)
def test_bad_images_are_clear_errors(image, match):
    with pytest.raises(SimroadError, match=match):
        apply_noise(image, "fog", severity=0.5, rng=0)


def test_context_must_match_the_image(scene):
    w = make_weather("fog", severity=0.5)
    w.reset(0)
    img = scene.frame.rgb
    with pytest.raises(SimroadError, match=r"depth: expected shape \(180, 320\)"):
        w.apply(img, scene.ctx(depth=np.ones((10, 10), dtype=np.float32)))
    with pytest.raises(SimroadError, match="camera: its image size 320x180 does not match the image's 160x90"):
        w.apply(np.ascontiguousarray(img[::2, ::2]), scene.ctx())
    with pytest.raises(SimroadError, match="ctx: expected a NoiseContext"):
        w.apply(img, {"camera": scene.camera})


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(depth=np.ones((4, 4), dtype=np.uint8)), "depth: expected a float"),
        (dict(depth=np.full((4, 4), np.nan)), "depth: contains NaN"),
        (dict(depth=np.full((4, 4), -5.0)), r"^depth: contains negative distances \(down to -5 m\)"),  # fog brightened
        (dict(vehicles=5), r"^vehicles: expected a sequence of VehicleBox"),  # was 'int' object is not iterable
        (dict(material=np.ones((4, 4), dtype=np.float32)), "material: expected a uint8"),
        (dict(dt=0.0), "dt"),
        (dict(ego_speed=math.nan), "ego_speed"),
        (dict(vehicles=[1]), r"vehicles\[0\]"),
        (dict(camera="cam"), "camera: expected a simroad.camera.PinholeCamera"),
    ],
)
def test_bad_contexts_are_clear_errors(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        NoiseContext(**kwargs)


def test_rng_is_required_and_never_global():
    img = np.full((32, 32, 3), 100, dtype=np.uint8)
    with pytest.raises(SimroadError, match="rng"):
        apply_noise(img, "rain", severity=0.5, rng=None)


def test_srgb_round_trip_is_exact_for_every_grey_level():
    levels = np.repeat(np.arange(256, dtype=np.uint8)[:, None, None], 3, axis=2).reshape(16, 16, 3)
    np.testing.assert_array_equal(linear_to_srgb(srgb_to_linear(levels)), levels)


def test_a_noise_named_twice_is_refused_by_weather_as_by_parse_noise():
    with pytest.raises(SimroadError, match=r"^names: 'rain' given more than once"):
        Weather(("rain", "rain"), severity=0.5)  # was accepted as 'rain+rain'


@pytest.mark.parametrize("fn", [lambda a: change_mask(a, a), srgb_to_linear])
def test_empty_frames_are_refused_by_the_radiometry_functions(fn):
    with pytest.raises(SimroadError, match=r"expected at least 1x1 pixels, got shape \(0, 4, 3\)"):
        fn(np.zeros((0, 4, 3), np.uint8))  # change_mask raised 'NoneType' object is not subscriptable
