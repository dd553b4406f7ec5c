"""Every exported function of simroad.filters refuses bad arrays by name.

The table is keyed by ``simroad.filters.__all__``: an exported callable without an
entry (or a reason it takes no arrays) fails :func:`test_every_export_has_an_entry`,
so new exports are covered automatically. Each array function has at least one wrong
type, one out-of-range value and one non-finite array; each must end in a
:class:`SimroadError` (a ``ValueError``) whose message starts with the parameter's name.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import simroad.filters as F
from simroad.errors import SimroadError

IMG = np.random.default_rng(0).integers(0, 256, (12, 12, 3), dtype=np.uint8)
GREY = np.full((12, 12), 0.5, np.float32)


def _float(value: float, shape: tuple[int, ...] = (12, 12, 3)) -> np.ndarray:
    """A float32 image of 0.5 with one entry set to ``value``."""
    a = np.full(shape, 0.5, np.float32)
    a[(1,) * len(shape)] = value
    return a


NAN = _float(np.nan)
INF = _float(np.inf)
BIG = _float(1.5)

Case = tuple[str, Callable[[], object], str]  # (kind, call, parameter named in the error)


def _image_cases(fn: Callable[..., object], **range_kwargs: object) -> list[Case]:
    """Cases for a function whose first argument is an RGB image; ``range_kwargs`` is one bad option."""
    cases: list[Case] = [
        ("type", lambda: fn(IMG.tolist()), "image"),
        ("type-dtype", lambda: fn(IMG.astype(np.int16)), "image"),
        ("range", lambda: fn(BIG), "image"),
        ("finite", lambda: fn(NAN), "image"),
        ("finite-inf", lambda: fn(INF), "image"),
    ]
    for key, value in range_kwargs.items():
        cases.append((f"range-{key}", lambda key=key, value=value: fn(IMG, **{key: value}), key))
    return cases


#: Exported callables that take no arrays (and why); everything else is in CASES.
NOT_ARRAY_FUNCTIONS = {
    "FilterResult": "the named tuple the filters return; it holds their output",
    "FilterSpec": "a registry entry built from filter functions and settings, not arrays",
    "FilterStep": "one step of a registry entry: a function and its keyword settings",
}

#: Exported functions that take names, not arrays: type and range cases only.
NAME_FUNCTIONS = {"check_filters", "parse_filters", "format_filters"}

CASES: dict[str, list[Case]] = {
    "apply_filters": _image_cases(F.apply_filters, variant="best")
    + [
        ("type-filters", lambda: F.apply_filters(IMG, 5), "filters"),
        ("range-filters", lambda: F.apply_filters(IMG, ("fog!",)), "filters"),
    ],
    "box_mean": [
        ("type", lambda: F.box_mean(GREY.tolist(), 1), "x"),
        ("type-dtype", lambda: F.box_mean(GREY.astype(np.int32), 1), "x"),
        ("type-radius", lambda: F.box_mean(GREY, "2"), "radius"),
        ("range", lambda: F.box_mean(GREY, -1), "radius"),
        ("range-shape", lambda: F.box_mean(np.zeros((4, 4, 2, 2), np.float32), 1), "x"),
        ("range-channels", lambda: F.box_mean(np.zeros((4, 4, 129), np.float32), 1), "x"),
        ("range-empty", lambda: F.box_mean(np.zeros((0, 4), np.float32), 1), "x"),
        ("finite", lambda: F.box_mean(_float(np.nan, (12, 12)), 1), "x"),
        ("finite-inf", lambda: F.box_mean(_float(-np.inf, (12, 12)), 1), "x"),
    ],
    "check_filters": [
        ("type", lambda: F.check_filters(5), "filters"),
        ("range", lambda: F.check_filters(("fog",)), "filters"),
    ],
    "dark_channel": _image_cases(F.dark_channel, patch=4),
    "format_filters": [
        ("type", lambda: F.format_filters(5), "filters"),
        ("type-str", lambda: F.format_filters("shadow"), "filters"),
        ("range", lambda: F.format_filters(("fog",)), "filters"),
    ],
    "guided_filter": [
        ("type", lambda: F.guided_filter(GREY.tolist(), GREY, 1, 0.01), "guide"),
        ("type-src", lambda: F.guided_filter(GREY, GREY.astype(np.float64), 1, 0.01), "src"),
        ("range", lambda: F.guided_filter(GREY, GREY, 0, 0.01), "radius"),
        ("range-eps", lambda: F.guided_filter(GREY, GREY, 1, -1.0), "eps"),
        ("range-guide", lambda: F.guided_filter(_float(2.0, (12, 12)), GREY, 1, 0.01), "guide"),
        ("finite", lambda: F.guided_filter(GREY, _float(np.nan, (12, 12)), 1, 0.01), "src"),
        ("finite-guide", lambda: F.guided_filter(_float(np.inf, (12, 12)), GREY, 1, 0.01), "guide"),
        ("finite-eps", lambda: F.guided_filter(GREY, GREY, 1, float("nan")), "eps"),
    ],
    "ndi": _image_cases(F.ndi),
    "parse_filters": [
        ("type", lambda: F.parse_filters(5), "filters"),
        ("range", lambda: F.parse_filters("shadow+fog"), "filters"),
    ],
    "remove_colour_cast": _image_cases(F.remove_colour_cast, rows=0.0, gamma=0.5),
    "remove_glare": _image_cases(F.remove_glare, min_lift=0.0, fine=4),
    "remove_haze": _image_cases(F.remove_haze, t_min=0.0, percentile=80.0),
    "remove_highlights": _image_cases(F.remove_highlights, radius=0, iterations=-1),
    "remove_rain_snow": _image_cases(F.remove_rain_snow, eps=0.0, protect=-1),
    "remove_shadows": _image_cases(F.remove_shadows, ring=0, min_ndi=2.0),
    "relight_shadows": _image_cases(F.relight_shadows, window=2, min_drop=0.0),
    "specular_to_diffuse": [
        *_image_cases(
            lambda image, **kw: F.specular_to_diffuse(image, np.full((12, 12), 0.5), **kw), achromatic_tol=2.0
        ),
        ("type-lambda", lambda: F.specular_to_diffuse(IMG, np.full((12, 12), 0.5).tolist()), "lambda_max"),
        ("range-lambda", lambda: F.specular_to_diffuse(IMG, np.full((12, 12), 0.2)), "lambda_max"),
        ("range-lambda-shape", lambda: F.specular_to_diffuse(IMG, np.full((6, 12), 0.5)), "lambda_max"),
        ("finite-lambda", lambda: F.specular_to_diffuse(IMG, _float(np.nan, (12, 12))), "lambda_max"),
    ],
}


def _exported_callables(module) -> set[str]:
    return {name for name in module.__all__ if callable(getattr(module, name))}


def test_every_export_has_an_entry():
    exported = _exported_callables(F)
    assert exported - set(CASES) - set(NOT_ARRAY_FUNCTIONS) == set(), "add the new export to CASES"
    assert set(CASES) | set(NOT_ARRAY_FUNCTIONS) <= exported, "the table names something no longer exported"
    for name in NOT_ARRAY_FUNCTIONS:
        assert isinstance(getattr(F, name), type), f"{name} is a function: give it CASES"


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_array_function_has_each_kind_of_bad_input(name):
    kinds = {kind.split("-")[0] for kind, _, _ in CASES[name]}
    needed = {"type", "range"} if name in NAME_FUNCTIONS else {"type", "range", "finite"}
    assert needed <= kinds


@pytest.mark.parametrize(
    ("call", "param"),
    [
        pytest.param(call, param, id=f"{name}-{kind}")
        for name, cases in sorted(CASES.items())
        for kind, call, param in cases
    ],
)
def test_bad_input_is_refused_by_name(call, param):
    with pytest.raises(SimroadError) as info:
        call()
    assert isinstance(info.value, ValueError)
    assert str(info.value).startswith(f"{param}:"), str(info.value)


@pytest.mark.parametrize("fn", [F.ndi, F.dark_channel, lambda im: F.remove_shadows(im).image, F.apply_filters])
def test_non_finite_images_are_refused_as_finite_values(fn):
    with pytest.raises(SimroadError, match=r"^image: expected finite values, got 1 NaN or infinite value"):
        fn(NAN)


def test_box_mean_of_valid_input_is_unchanged():
    x = np.random.default_rng(1).random((7, 9, 2)).astype(np.float32)
    got = F.box_mean(x, 1)
    ref = np.stack([F.box_mean(np.ascontiguousarray(x[..., c]), 1) for c in range(2)], axis=-1)
    np.testing.assert_allclose(got, ref, rtol=1e-6)
    assert got.dtype == np.float32 and got.shape == x.shape
    np.testing.assert_array_equal(F.box_mean(x, 0), x)
    assert F.box_mean(x.astype(np.float64), 1).dtype == np.float64
