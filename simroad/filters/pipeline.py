"""Filter pipelines by name: the one registry of the detector's filters, their variants and order.

Each filter (``"shadow"``, ``"rain_snow"``, ``"light"``) is declared once in
:data:`FILTER_REGISTRY` as a :class:`FilterSpec`: its rank in the pipeline and, per
variant (:data:`FILTER_VARIANTS`), a pipeline of :class:`FilterStep` -- a public filter
function plus the keyword settings that differ from that function's defaults (the
defaults are read from its signature, so they live in one place). Everything else
refers to the filters by name: :func:`apply_filters` runs them,
:func:`parse_filters` / :func:`format_filters` read and write the text of a filter
set in records (``"shadow+rain_snow+light"``, ``"none"``).

Two orders, both derived from the registry:

* :data:`FILTERS`, the pipeline order (by rank): rain and snow first (their bright
  streaks would otherwise pass for highlights in the dark channel), then highlights,
  then shadows (NDI needs the true value V);
* :data:`FILTER_NAMES`, the order of the registry's declaration, used in the text of
  records and on the command line.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from simroad.core.names import NOISE_NAMES
from simroad.core.radiometry import CAMERA_TONE_GAMMA, GAMMA
from simroad.core.validation import IMAGE_DTYPES, check_choice, check_image
from simroad.errors import InvalidParameterError
from simroad.filters._common import (
    FilterResult,
    Planes,
    clip_planes,
    from_planes,
    gate_preview,
    to_planes,
)
from simroad.filters.glare import _glare_planes, remove_glare
from simroad.filters.haze import _haze_planes, remove_haze
from simroad.filters.highlights import _highlights_planes, remove_highlights
from simroad.filters.illuminant import _colour_cast_planes, remove_colour_cast
from simroad.filters.rain_snow import _rain_snow_planes, remove_rain_snow
from simroad.filters.relight import _relight_planes, relight_shadows
from simroad.filters.shadow import _shadows_planes, remove_shadows

__all__ = [
    "FILTERS",
    "FILTER_NAMES",
    "FILTER_REGISTRY",
    "FILTER_VARIANTS",
    "FilterSpec",
    "FilterStep",
    "apply_filters",
    "check_filters",
    "check_variant",
    "filter_planes",
    "filter_planes_masks",
    "format_filters",
    "parse_filters",
]

#: Public filter -> its core on float32 planes (same keyword options, no defaults).
_CORES: dict[Callable[..., FilterResult], Callable[..., tuple[Planes, np.ndarray]]] = {
    remove_colour_cast: _colour_cast_planes,
    remove_glare: _glare_planes,
    remove_haze: _haze_planes,
    remove_highlights: _highlights_planes,
    remove_rain_snow: _rain_snow_planes,
    remove_shadows: _shadows_planes,
    relight_shadows: _relight_planes,
}


#: Cores that can write their result into the planes they are given (``inplace=True``)
#: and take a shared :func:`~simroad.filters._common.gate_preview` of them (``preview=``).
_IN_PLACE = frozenset({_colour_cast_planes, _glare_planes, _haze_planes, _relight_planes})


def _keyword_defaults(function: Callable[..., Any]) -> dict[str, Any]:
    return {
        name: p.default
        for name, p in inspect.signature(function).parameters.items()
        if p.kind is inspect.Parameter.KEYWORD_ONLY and p.default is not inspect.Parameter.empty
    }


@dataclass(frozen=True)
class FilterStep:
    """One step of a pipeline: a public filter function run with keyword settings.

    Parameters
    ----------
    function : callable
        One of the public filters (``remove_shadows``, ``remove_rain_snow``,
        ``remove_haze``, ``remove_highlights``, ``remove_glare``).
    settings : mapping of str to object, optional
        The keyword options that differ from ``function``'s defaults.

    Attributes
    ----------
    options : mapping of str to object
        Every keyword option of the step: ``function``'s defaults updated by
        ``settings``. Running the step on planes is the same as calling
        ``function(image, **options)`` on the image.
    """

    function: Callable[..., FilterResult]
    settings: Mapping[str, Any] = field(default_factory=dict)
    options: Mapping[str, Any] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.function not in _CORES:
            names = ", ".join(f.__name__ for f in _CORES)
            raise InvalidParameterError(
                f"function: expected one of the public filters ({names}), got {self.function!r}."
            )
        defaults = _keyword_defaults(self.function)
        unknown = sorted(set(self.settings) - set(defaults))
        if unknown:
            raise InvalidParameterError(
                f"settings: {self.function.__name__} has no keyword option {unknown}; "
                f"expected some of {sorted(defaults)}."
            )
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))
        object.__setattr__(self, "options", MappingProxyType({**defaults, **self.settings}))

    def run(self, planes: Planes) -> tuple[Planes, np.ndarray]:
        """Run the step on three float32 (H, W) planes in [0, 1]: (new planes, bool (H, W) mask)."""
        out, mask = _CORES[self.function](planes, **self.options)
        return ([p.copy() for p in planes] if out is planes else out), mask


def _step(function: Callable[..., FilterResult], **settings: Any) -> FilterStep:
    return FilterStep(function, settings)


@dataclass(frozen=True)
class FilterSpec:
    """One named filter of the detector.

    Parameters
    ----------
    name : str
        The filter's name in APIs, records and on the command line.
    rank : int
        Position in the pipeline (lower runs first), see :data:`FILTERS`.
    paper : tuple of FilterStep
        The steps as the paper's §III describes the filter.
    improved : tuple of FilterStep or None, optional
        The steps of the ``"improved"`` variant; None (default) when it is the
        paper's pipeline unchanged.
    weathers : tuple of str, optional
        The noises (``simroad.noise`` names) the filter is built to undo;
        ``simroad filter-effect`` measures it on each of them.
    """

    name: str
    rank: int
    paper: tuple[FilterStep, ...]
    improved: tuple[FilterStep, ...] | None = None
    weathers: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for noise in self.weathers:
            check_choice("weathers", noise, NOISE_NAMES)

    def steps(self, variant: str) -> tuple[FilterStep, ...]:
        """The pipeline of ``variant`` (``"improved"`` or ``"paper"``)."""
        if check_variant(variant) == "improved" and self.improved is not None:
            return self.improved
        return self.paper


#: How the filters are run: ``"improved"`` (default) with the corrections that make each
#: one lower FNR + FPR on its weather, ``"paper"`` as §III describes them (see README).
FILTER_VARIANTS = ("improved", "paper")

#: The improved rain/snow filter's veil tolerance (linear radiance over the near ground's
#: floor still taken as clear air). Its haze model is linear in radiance, so the frame is
#: decoded with the camera's own exponent (display = linear ** (CAMERA_TONE_GAMMA /
#: GAMMA)), as the light filter decodes it. Measured on snow and rain at 0.7, worlds
#: 110-112: 0.045 left snow FNR at 0.211 -> 0.191, 0.02 takes it to 0.143 (rain 0.284 ->
#: 0.255) and leaves every clear frame unchanged; 0.01 reached 0.127 but acted on clear frames.
_HAZE_TOLERANCE = 0.02

#: Every filter, declared once, in the order of record text (``shadow+rain_snow+light``).
#: Improved variants (``simroad filter-effect`` measures each, README): the rain/snow
#: filter undoes the haze of the falling particles row by row (its guided-filter
#: particle step, kept in the paper's variant, changed no score in rain or snow on the
#: validation worlds and cost clean frames FPR); the light filter
#: subtracts the sun's additive lobe instead of applying eq. 27; the shadow filter
#: first undoes a colour cast of the light beyond clear weather's (the sun and the blue
#: sky instead of the overcast the detector learnt under), then relights the cast
#: shadows by the frame's one sky/sun ratio in linear light (:mod:`simroad.filters.relight`).
FILTER_REGISTRY: Mapping[str, FilterSpec] = MappingProxyType(
    {
        spec.name: spec
        for spec in (
            FilterSpec(
                "shadow",
                rank=2,
                paper=(_step(remove_shadows),),
                improved=(_step(remove_colour_cast), _step(relight_shadows)),
                weathers=("shadow",),
            ),
            FilterSpec(
                "rain_snow",
                rank=0,
                paper=(_step(remove_rain_snow),),
                improved=(_step(remove_haze, tolerance=_HAZE_TOLERANCE, gamma=GAMMA / CAMERA_TONE_GAMMA),),
                weathers=("rain", "snow"),
            ),
            FilterSpec(
                "light",
                rank=1,
                paper=(_step(remove_highlights),),
                improved=(_step(remove_glare),),
                weathers=("glare",),
            ),
        )
    }
)
#: Filter names in the order of record text and the command line.
FILTER_NAMES = tuple(FILTER_REGISTRY)
#: Filter names in the order the pipeline applies them (by rank).
FILTERS = tuple(sorted(FILTER_NAMES, key=lambda name: FILTER_REGISTRY[name].rank))


def check_filters(filters: object) -> tuple[str, ...]:
    """Validate a set of filter names (a sequence, one name, or None); return it in pipeline order."""
    if isinstance(filters, str):
        filters = (filters,)
    if filters is None:
        filters = ()
    try:
        names = list(filters)  # type: ignore[call-overload]
    except TypeError:
        raise InvalidParameterError(
            f"filters: expected a sequence of filter names from {FILTERS}, got {filters!r}."
        ) from None
    for name in names:
        check_choice("filters", name, FILTERS)
    return tuple(f for f in FILTERS if f in names)


def check_variant(variant: object) -> str:
    """Validate a filter variant, one of :data:`FILTER_VARIANTS`."""
    return check_choice("filter_variant", variant, FILTER_VARIANTS)


def filter_planes(planes: Planes, filters: tuple[str, ...], variant: str = "improved") -> Planes:
    """Run validated filters (pipeline order) on float32 planes in [0, 1]; new planes in [0, 1].

    Each filter's steps run in turn, and the planes are clipped after each filter.
    """
    return filter_planes_masks(planes, filters, variant)[0]


def filter_planes_masks(
    planes: Planes, filters: tuple[str, ...], variant: str = "improved"
) -> tuple[Planes, dict[str, np.ndarray]]:
    """:func:`filter_planes`, and where each filter acted: ``{name: bool (H, W)}``, its steps' masks united."""
    out, masks = _filter_planes_masks(planes, filters, variant)
    return ([p.copy() for p in planes] if out is planes else out), masks


def _filter_planes_masks(
    planes: Planes, filters: tuple[str, ...], variant: str = "improved", *, owned: bool = False
) -> tuple[Planes, dict[str, np.ndarray]]:
    """:func:`filter_planes_masks` that may hand back ``planes`` itself when no filter changed them.

    A filter core returns the very list it was given when it leaves the planes as they
    are (no weather to undo); then nothing is copied, and the filter's clip is skipped
    (the planes already lie in [0, 1]). The cores of :data:`_IN_PLACE` write into planes
    the pipeline owns -- its own intermediates, and ``planes`` too when ``owned`` (the
    caller hands them over) -- instead of new ones.
    """
    out, masks = planes, {}
    preview, previewed = None, None  # gate_preview of the planes ``previewed``, made once for every gate
    for name in filters:
        before, acted = out, None
        for step in FILTER_REGISTRY[name].steps(variant):
            core = _CORES[step.function]
            extra: dict[str, Any] = {}
            if core in _IN_PLACE:  # the cores that act in place gate on a preview of a large frame
                if previewed is not out:
                    preview, previewed = gate_preview(out), out
                extra["preview"] = preview
            if core in _IN_PLACE and (owned or out is not planes):
                extra["inplace"] = True
            out, mask = core(out, **step.options, **extra)
            acted = mask if acted is None else acted | mask
        if out is not before:
            clip_planes(out)
        masks[name] = acted if acted is not None else np.zeros(planes[0].shape, bool)
    return out, masks


def apply_filters(image: np.ndarray, filters: Sequence[str] = FILTERS, *, variant: str = "improved") -> np.ndarray:
    """Apply a set of the detector's filters by name, each with its registered settings.

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    filters : sequence of str
        Any subset of :data:`FILTER_NAMES`; applied in the order of :data:`FILTERS`
        whatever the order given.
    variant : {"improved", "paper"}, optional
        ``"paper"`` runs the filters as §III describes them; ``"improved"`` (default)
        with the corrections the detector uses (see :data:`FILTER_REGISTRY`).

    Returns
    -------
    ndarray, same shape and dtype as ``image``
        A new array.
    """
    image = check_image("image", image, dtype=IMAGE_DTYPES, channels=3)
    names = check_filters(filters)
    variant = check_choice("variant", variant, FILTER_VARIANTS)
    if not names:
        return image.copy()
    return from_planes(_filter_planes_masks(to_planes(image), names, variant, owned=True)[0], image.dtype)


def parse_filters(spec: str | Sequence[str]) -> tuple[str, ...]:
    """``"none"`` -> (), ``"all"`` -> every filter, ``"shadow+light"`` -> that set.

    Returns the filters in record order (:data:`FILTER_NAMES`); unknown names are
    refused with the valid ones listed.
    """
    if isinstance(spec, str):
        text = spec.strip()
        if text in ("", "none"):
            return ()
        if text == "all":
            return FILTER_NAMES
        names = [n.strip() for n in text.split("+")]
    else:
        names = _name_list(spec)
    out = []
    for n in names:
        check_choice("filters", n, FILTER_NAMES + ("none", "all") if len(names) == 1 else FILTER_NAMES)
        if n in out:
            raise InvalidParameterError(f"filters: {n!r} is listed twice in {spec!r}.")
        out.append(n)
    return tuple(f for f in FILTER_NAMES if f in out)


def format_filters(filters: Sequence[str]) -> str:
    """The canonical text of a filter set: ``none`` or names joined by ``+`` (in the order given)."""
    names = _name_list(filters)
    for name in names:
        check_choice("filters", name, FILTER_NAMES)
    return "+".join(names) if names else "none"


def _name_list(filters: object) -> list[str]:
    """A sequence of filter names as a list; anything else is refused naming ``filters``."""
    if isinstance(filters, (str, bytes)) or not isinstance(filters, Sequence):
        raise InvalidParameterError(
            f"filters: expected a sequence (list or tuple) of filter names from {FILTER_NAMES}, got "
            f"{type(filters).__name__} {filters!r}."
        )
    return list(filters)
