"""The detector's filtering stage (paper §III-B): plain functions on arrays.

Every filter takes an ``(H, W, 3)`` RGB image, ``uint8`` or float in [0, 1], returns
the same shape and dtype, never modifies its input and is deterministic.
"""

from __future__ import annotations

from simroad.filters.guided import box_mean, guided_filter
from simroad.filters.haze import remove_haze
from simroad.filters.light import dark_channel, remove_glare, remove_highlights, specular_to_diffuse
from simroad.filters.rain_snow import remove_rain_snow
from simroad.filters.shadow import ndi, remove_shadows

__all__ = [
    "box_mean",
    "dark_channel",
    "guided_filter",
    "ndi",
    "remove_glare",
    "remove_haze",
    "remove_highlights",
    "remove_rain_snow",
    "remove_shadows",
    "specular_to_diffuse",
]
