"""A camera profile: the camera's response and the daylight and asphalt of its places.

Everything that decides how a clear day *looks* and that differs between one real
camera (and the streets it drives) and another, in one validated, recordable set
(docs/realism.md has the physics and the sources):

the camera
    ``exposure_bias_ev`` (the auto-exposure's target, in stops from simroad's),
    ``exposure_spread_ev`` (the spread of the meter's bias from scene to scene),
    ``wb_preset_k`` and ``awb_strength`` (the white balance: a daylight preset the
    auto white balance moves a share of the way to the scene's light, in mired),
    ``tone_gamma`` and ``tone_shoulder`` (the response curve: contrast and the
    highlight roll-off), ``saturation`` (the chroma gain after the gamma), ``full_well_e`` (the pixel's full well: its noise);
the daylight
    ``overcast_share`` and ``hazy_share`` (the rest is sunny), the sun's elevation
    range ``sun_elevation_deg`` and the sky's brightness range ``sky_brightness``
    (relative to the lit ground);
the asphalt
    ``asphalt_scale`` (a factor on the measured albedo ranges: a region's binder and
    aggregate) and ``aged_share`` (the share of roads of worn, paler asphalt).

``CameraProfile()`` is simroad's default; ``simroad calibrate`` fits one to a user's
photographs and writes it as TOML (:func:`load_profile` reads it back, refusing
unknown keys and values out of range by name).
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import tomllib
from dataclasses import dataclass
from typing import Any

from simroad.core.daylight import CCT_RANGE_K
from simroad.core.radiometry import CAMERA_SHOULDER, CAMERA_TONE_GAMMA
from simroad.core.validation import check_fields_in_range, check_in_range, check_input_file
from simroad.errors import InvalidParameterError

__all__ = [
    "CAMERA_FIELDS",
    "PROFILE_RANGES",
    "CameraProfile",
    "load_profile",
    "profile_from_dict",
    "resolve_profile",
    "save_profile",
]

#: Each scalar field's valid range: (low, high, unit).
PROFILE_RANGES: dict[str, tuple[float, float, str]] = {
    "exposure_bias_ev": (-3.0, 3.0, "EV"),
    "exposure_spread_ev": (0.0, 2.0, "EV"),
    "wb_preset_k": (CCT_RANGE_K[0], 10000.0, "K"),
    "awb_strength": (0.0, 1.0, ""),
    "tone_gamma": (0.5, 3.0, ""),
    "tone_shoulder": (0.0, 20.0, ""),
    "saturation": (0.0, 3.0, ""),
    "full_well_e": (500.0, 1e5, "e-"),
    "overcast_share": (0.0, 1.0, ""),
    "hazy_share": (0.0, 1.0, ""),
    "asphalt_scale": (0.4, 2.5, ""),
    "aged_share": (0.0, 1.0, ""),
}
#: Each range field's bounds: (low, high, unit).
_PAIR_RANGES: dict[str, tuple[float, float, str]] = {
    "sun_elevation_deg": (2.0, 90.0, "degrees"),
    "sky_brightness": (0.2, 5.0, ""),
}


@dataclass(frozen=True)
class CameraProfile:
    """How a clear day looks: the camera, the daylight, the asphalt (module docstring)."""

    exposure_bias_ev: float = 0.0
    exposure_spread_ev: float = 0.4
    wb_preset_k: float = 4800.0
    awb_strength: float = 0.55
    tone_gamma: float = CAMERA_TONE_GAMMA
    tone_shoulder: float = CAMERA_SHOULDER
    saturation: float = 1.2
    full_well_e: float = 6000.0
    overcast_share: float = 0.5
    hazy_share: float = 0.25
    sun_elevation_deg: tuple[float, float] = (5.0, 65.0)
    sky_brightness: tuple[float, float] = (0.8, 1.8)
    asphalt_scale: float = 1.0
    aged_share: float = 0.8

    def __post_init__(self) -> None:
        ranges = {k: (lo, hi, unit, True) for k, (lo, hi, unit) in PROFILE_RANGES.items()}
        for name, value in check_fields_in_range(self, ranges).items():
            object.__setattr__(self, name, value)
        if self.overcast_share + self.hazy_share > 1.0 + 1e-9:
            raise InvalidParameterError(
                f"overcast_share + hazy_share: expected at most 1 (the rest is sunny), got "
                f"{self.overcast_share:g} + {self.hazy_share:g}. Lower one of them."
            )
        for name, (lo, hi, unit) in _PAIR_RANGES.items():
            pair = getattr(self, name)
            if isinstance(pair, (str, bytes)) or not hasattr(pair, "__len__") or len(pair) != 2:
                raise InvalidParameterError(f"{name}: expected a pair [low, high], got {pair!r}.")
            a = check_in_range(f"{name}[0]", pair[0], lo, hi, unit=unit)
            b = check_in_range(f"{name}[1]", pair[1], lo, hi, unit=unit)
            if b < a:
                raise InvalidParameterError(f"{name}: expected low <= high, got [{a:g}, {b:g}]. Swap them.")
            object.__setattr__(self, name, (a, b))

    def as_dict(self) -> dict[str, Any]:
        """The profile as plain values (what episode records and TOML files hold)."""
        return {
            f.name: list(v) if isinstance(v := getattr(self, f.name), tuple) else v for f in dataclasses.fields(self)
        }


_FIELDS = tuple(f.name for f in dataclasses.fields(CameraProfile))
#: The fields that act in the camera's sensor alone (:meth:`SensorParams.with_profile
#: <simroad.camera.sensor_params.SensorParams.with_profile>`), after the renderer; the
#: others (daylight, asphalt) change the world that is rendered.
CAMERA_FIELDS = (
    "exposure_bias_ev",
    "exposure_spread_ev",
    "wb_preset_k",
    "awb_strength",
    "tone_gamma",
    "tone_shoulder",
    "saturation",
    "full_well_e",
)


def _hint(key: str) -> str:
    close = difflib.get_close_matches(str(key), _FIELDS, n=1, cutoff=0.5)
    return f" Did you mean {close[0]!r}?" if close else ""


def profile_from_dict(values: dict[str, Any], *, where: str = "camera_profile") -> CameraProfile:
    """A profile from a mapping of field names (unknown names refused with a suggestion)."""
    if not isinstance(values, dict):
        raise InvalidParameterError(f"{where}: expected a table of profile values, got {type(values).__name__}.")
    for key in values:
        if key not in _FIELDS:
            raise InvalidParameterError(
                f"{where}: unknown profile key {key!r}; valid keys are {', '.join(_FIELDS)}.{_hint(key)}"
            )
    kw: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
    try:
        return CameraProfile(**kw)
    except InvalidParameterError as exc:  # name where the bad value came from
        raise InvalidParameterError(f"{where}: {exc}") from None


def load_profile(path: str | os.PathLike) -> CameraProfile:
    """Read a profile from a TOML file (its ``[camera_profile]`` table, or the top level)."""
    p = check_input_file("camera_profile", path)
    try:
        with open(p, "rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise InvalidParameterError(f"camera_profile: {str(p)!r} is not valid TOML ({exc}).") from None
    table = data.get("camera_profile", data)
    table = {k: v for k, v in table.items() if k != "fit"}  # calibrate's report of the fit
    return profile_from_dict(table, where=f"camera_profile ({p.name})")


def save_profile(profile: CameraProfile, path: str | os.PathLike, *, comment: str = "") -> None:
    """Write ``profile`` as TOML (a ``[camera_profile]`` table) that :func:`load_profile` reads."""
    lines = [f"# {line}" for line in comment.splitlines()] + ["[camera_profile]"]
    for k, v in profile.as_dict().items():
        lines.append(f"{k} = [{v[0]!r}, {v[1]!r}]" if isinstance(v, list) else f"{k} = {v!r}")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def resolve_profile(value: Any) -> CameraProfile:
    """``None`` (the default profile), a :class:`CameraProfile`, a TOML path or a dict."""
    if value is None:
        return CameraProfile()
    if isinstance(value, CameraProfile):
        return value
    if isinstance(value, dict):
        return profile_from_dict(value)
    if isinstance(value, (str, os.PathLike)):
        return load_profile(value)
    raise InvalidParameterError(
        f"camera_profile: expected a CameraProfile, a path to a TOML profile or a dict, got {type(value).__name__}."
    )
