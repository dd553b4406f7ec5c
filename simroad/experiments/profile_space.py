"""The search space of ``simroad calibrate``: profile fields as coordinates in [0, 1].

Each fitted scalar field of :data:`~simroad.camera.profile.PROFILE_RANGES` is one
coordinate over its whole range (the white balance in mired, so that equal steps are
equal colour shifts); ``sky_brightness`` is two (its ends, sorted back into a range);
condition shares that pass a sum of 1 are scaled down to it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from typing import Any

import numpy as np

from simroad.camera.profile import PROFILE_RANGES, CameraProfile
from simroad.core.validation import check_choice
from simroad.errors import InvalidParameterError

__all__ = [
    "FITTABLE",
    "FIT_PARAMETERS",
    "SKY_BRIGHTNESS_RANGE",
    "check_fit",
    "from_unit",
    "simplex",
    "to_unit",
    "unit_coordinates",
]

#: Fields ``simroad calibrate`` fits by default (``sky_brightness`` is a range: two numbers).
FIT_PARAMETERS = (
    "exposure_bias_ev",
    "exposure_spread_ev",
    "wb_preset_k",
    "awb_strength",
    "tone_gamma",
    "asphalt_scale",
    "sky_brightness",
    "overcast_share",
    "hazy_share",
)
#: Fields that may be fitted: the scalar fields of PROFILE_RANGES and the sky's brightness range.
FITTABLE = (*PROFILE_RANGES, "sky_brightness")
#: The range the search gives each end of ``sky_brightness`` (relative to the lit ground).
SKY_BRIGHTNESS_RANGE = (0.2, 5.0)


def check_fit(fit: Any) -> tuple[str, ...]:
    """``fit`` as a tuple of fittable field names (unknown names refused with a suggestion)."""
    if isinstance(fit, str) or not isinstance(fit, Iterable):
        raise InvalidParameterError(f"fit: expected a list of profile fields, got {fit!r}.")
    names = tuple(fit)
    if not names:
        raise InvalidParameterError(f"fit: expected at least one of {', '.join(FITTABLE)}, got none.")
    for name in names:
        check_choice("fit", name, FITTABLE)
    if len(set(names)) != len(names):
        raise InvalidParameterError(f"fit: duplicate fields in {list(names)}.")
    return names


def _mired(k: float) -> float:
    return 1e6 / k


def _bounds(name: str) -> tuple[float, float]:
    """The search's range of one coordinate (the white balance in mired, low to high)."""
    if name == "sky_brightness":
        return SKY_BRIGHTNESS_RANGE
    lo, hi, _ = PROFILE_RANGES[name]
    return (_mired(hi), _mired(lo)) if name == "wb_preset_k" else (lo, hi)


def unit_coordinates(fit: tuple[str, ...]) -> list[tuple[str, int]]:
    """(field, index) of each search coordinate: the sky's range has two."""
    return [(n, i) for n in fit for i in ((0, 1) if n == "sky_brightness" else (0,))]


def to_unit(profile: CameraProfile, coords: list[tuple[str, int]]) -> np.ndarray:
    x = []
    for name, i in coords:
        value = getattr(profile, name)
        value = value[i] if name == "sky_brightness" else value
        value = _mired(value) if name == "wb_preset_k" else value
        lo, hi = _bounds(name)
        x.append(float(np.clip((value - lo) / (hi - lo), 0.0, 1.0)))
    return np.array(x)


def from_unit(x: np.ndarray, start: CameraProfile, coords: list[tuple[str, int]]) -> CameraProfile:
    """The profile at unit coordinates ``x`` (each clipped to [0, 1]); the sky's ends
    sorted, the condition shares scaled down to a sum of 1 when they pass it."""
    values: dict[str, Any] = {}
    sky = list(start.sky_brightness)
    for (name, i), u in zip(coords, np.clip(x, 0.0, 1.0)):
        lo, hi = _bounds(name)
        v = lo + float(u) * (hi - lo)
        if name == "sky_brightness":
            sky[i] = v
        else:
            values[name] = 1e6 / v if name == "wb_preset_k" else v
    if any(n == "sky_brightness" for n, _ in coords):
        values["sky_brightness"] = (min(sky), max(sky))
    o = values.get("overcast_share", start.overcast_share)
    h = values.get("hazy_share", start.hazy_share)
    if o + h > 1.0:
        values["overcast_share"], values["hazy_share"] = o / (o + h), h / (o + h)
    values = {k: _clip_field(k, _round(v)) for k, v in values.items()}
    return dataclasses.replace(start, **values)


def _round(value: Any) -> Any:
    """Five significant digits (what a profile file shows; far finer than the fit resolves)."""
    if isinstance(value, tuple):
        return tuple(_round(v) for v in value)
    return float(f"{value:.5g}")


def _clip_field(name: str, value: Any) -> Any:
    """Guard against rounding past a field's range (1e6 / (1e6 / k) is not always k)."""
    if name in PROFILE_RANGES:
        lo, hi, _ = PROFILE_RANGES[name]
        return float(min(max(value, lo), hi))
    return value


def simplex(x0: np.ndarray, step: float = 0.2) -> np.ndarray:
    """Nelder-Mead's first simplex: ``x0`` and one step along each axis, inwards."""
    pts = [x0]
    for i in range(x0.size):
        p = x0.copy()
        p[i] = x0[i] + step if x0[i] + step <= 1.0 else x0[i] - step
        pts.append(p)
    return np.array(pts)
