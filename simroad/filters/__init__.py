"""The detector's filtering stage (paper §III-B): plain functions on arrays and named pipelines of them.

Every public filter (``remove_*``) takes an ``(H, W, 3)`` RGB image, ``uint8`` or float
in [0, 1], and keyword-only options; it returns a :class:`FilterResult` -- the filtered
image (same shape and dtype) and the bool ``(H, W)`` mask of the pixels it acted on --
never modifies its input and is deterministic. The detector's filters are named
pipelines of those functions (:data:`FILTER_REGISTRY`), run by name with
:func:`apply_filters`.
"""

from __future__ import annotations

from simroad.filters._common import FilterResult
from simroad.filters.glare import remove_glare
from simroad.filters.guided import box_mean, guided_filter
from simroad.filters.haze import remove_haze
from simroad.filters.highlights import dark_channel, remove_highlights, specular_to_diffuse
from simroad.filters.illuminant import remove_colour_cast
from simroad.filters.pipeline import (
    FILTER_NAMES,
    FILTER_REGISTRY,
    FILTER_VARIANTS,
    FILTERS,
    FilterSpec,
    FilterStep,
    apply_filters,
    check_filters,
    format_filters,
    parse_filters,
)
from simroad.filters.rain_snow import remove_rain_snow
from simroad.filters.relight import relight_shadows
from simroad.filters.shadow import ndi, remove_shadows

__all__ = [
    "FILTERS",
    "FILTER_NAMES",
    "FILTER_REGISTRY",
    "FILTER_VARIANTS",
    "FilterResult",
    "FilterSpec",
    "FilterStep",
    "apply_filters",
    "box_mean",
    "check_filters",
    "dark_channel",
    "format_filters",
    "guided_filter",
    "ndi",
    "parse_filters",
    "relight_shadows",
    "remove_colour_cast",
    "remove_glare",
    "remove_haze",
    "remove_highlights",
    "remove_rain_snow",
    "remove_shadows",
    "specular_to_diffuse",
]
