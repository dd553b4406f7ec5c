"""The filter registry: names, orders, steps equal to their public functions, parse/format."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import (
    FILTER_NAMES,
    FILTER_REGISTRY,
    FILTER_VARIANTS,
    FILTERS,
    FilterStep,
    apply_filters,
    check_filters,
    format_filters,
    parse_filters,
    remove_haze,
    remove_rain_snow,
    remove_shadows,
)
from simroad.filters._common import to_planes
from simroad.filters.pipeline import check_variant


def _scene(shape=(48, 80)) -> np.ndarray:
    """float32 sky, grass, asphalt with a marking, a cast shadow, a clipped glare band and flakes."""
    rng = np.random.default_rng(1)
    h, w = shape
    img = np.empty((h, w, 3))
    img[: h // 4] = 0.8
    img[h // 4 :] = (0.34, 0.46, 0.23)
    img[h // 4 :, w // 4 : 3 * w // 4] = 0.35
    img[h // 4 :, w // 2 - 1 : w // 2 + 1] = 0.9
    img += rng.normal(0, 0.02, img.shape)
    img[h // 2 : h // 2 + 8, w // 4 : w // 2] *= (0.2, 0.25, 0.35)
    img[h - 10 : h - 4, w // 3 :] += 0.7
    img[rng.integers(0, h, 30), rng.integers(0, w, 30)] = 0.97
    return np.clip(img, 0, 1).astype(np.float32)


def test_orders():
    assert FILTERS == ("rain_snow", "light", "shadow")  # pipeline order
    assert FILTER_NAMES == ("shadow", "rain_snow", "light")  # record text order
    assert FILTER_VARIANTS == ("improved", "paper")
    assert [FILTER_REGISTRY[n].rank for n in FILTERS] == sorted(FILTER_REGISTRY[n].rank for n in FILTERS)


def test_the_improved_shadow_filter_balances_the_light_then_relights():
    spec = FILTER_REGISTRY["shadow"]
    assert [s.function.__name__ for s in spec.steps("paper")] == ["remove_shadows"]
    assert [s.function.__name__ for s in spec.steps("improved")] == ["remove_colour_cast", "relight_shadows"]
    assert not spec.steps("paper")[0].settings  # the paper's step stays literal
    assert FILTER_REGISTRY["light"].steps("paper") != FILTER_REGISTRY["light"].steps("improved")


def test_step_settings_default_to_the_public_functions_defaults():
    (haze,) = FILTER_REGISTRY["rain_snow"].steps("improved")
    defaults = {k: p.default for k, p in inspect.signature(remove_haze).parameters.items() if k != "image"}
    settings = {"tolerance": 0.02, "gamma": pytest.approx(2.2 / 1.6)}  # decoded with the camera's exponent
    assert haze.function is remove_haze and dict(haze.settings) == settings
    assert dict(haze.options) == {**defaults, **settings}
    (particles,) = FILTER_REGISTRY["rain_snow"].steps("paper")
    assert particles.function is remove_rain_snow and not particles.settings
    with pytest.raises(TypeError):
        haze.options["tolerance"] = 1  # type: ignore[index]


def _every_step():
    for name, spec in FILTER_REGISTRY.items():
        for variant in FILTER_VARIANTS:
            for k, step in enumerate(spec.steps(variant)):
                yield pytest.param(step, id=f"{name}-{variant}-{k}-{step.function.__name__}")


@pytest.mark.parametrize("step", list(_every_step()))
def test_each_step_is_its_public_function_with_its_options(step):
    """Running a step on planes is calling the public function (which validates the settings)."""
    image = _scene()
    public, public_mask = step.function(image, **step.options)
    planes, mask = step.run(to_planes(image))
    ours = np.clip(np.stack(planes, axis=-1), 0, 1)
    np.testing.assert_array_equal(ours, public)
    np.testing.assert_array_equal(mask, public_mask)


def test_apply_filters_runs_the_registered_steps_in_pipeline_order():
    image = _scene()
    expect = image
    for name in FILTERS:
        for step in FILTER_REGISTRY[name].steps("improved"):
            expect = step.function(expect, **step.options).image
    np.testing.assert_array_equal(apply_filters(image, ("shadow", "light", "rain_snow")), expect)
    np.testing.assert_array_equal(apply_filters(image, ()), image)


def test_filter_steps_refuse_unknown_settings_and_functions():
    with pytest.raises(SimroadError, match="radius"):
        FilterStep(remove_shadows, {"radius": 3})
    with pytest.raises(SimroadError, match="public filters"):
        FilterStep(np.clip, {})


def test_check_filters_and_variants():
    assert check_filters(["shadow", "rain_snow"]) == ("rain_snow", "shadow")
    assert check_filters("light") == ("light",) and check_filters(None) == ()
    with pytest.raises(SimroadError, match="expected one of"):
        check_filters(["shadows"])
    with pytest.raises(SimroadError, match=r"^variant: unknown value 'better'"):  # its own parameter's name
        apply_filters(_scene(), ("shadow",), variant="better")
    with pytest.raises(SimroadError, match=r"^filter_variant"):
        check_variant("better")


def test_parse_and_format_filters():
    assert parse_filters("none") == () and parse_filters("") == ()
    assert parse_filters("all") == ("shadow", "rain_snow", "light")
    assert parse_filters("light+shadow") == ("shadow", "light")
    assert parse_filters(["rain_snow", "shadow"]) == ("shadow", "rain_snow")
    assert format_filters(parse_filters("all")) == "shadow+rain_snow+light"
    assert format_filters(()) == "none"
    with pytest.raises(SimroadError, match="twice"):
        parse_filters("light+light")
    with pytest.raises(SimroadError, match="filters"):
        parse_filters("all+shadow")


def test_every_filter_names_the_weathers_it_undoes():
    from simroad.core.names import NOISE_NAMES
    from simroad.filters import FILTER_REGISTRY

    for spec in FILTER_REGISTRY.values():
        assert spec.weathers, spec.name
        assert set(spec.weathers) <= set(NOISE_NAMES), spec.name
    # Each of the paper's noises has exactly one filter meant for it.
    claimed = [w for spec in FILTER_REGISTRY.values() for w in spec.weathers]
    assert sorted(claimed) == sorted({"shadow", "rain", "snow", "glare"})
