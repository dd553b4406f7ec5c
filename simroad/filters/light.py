"""The light filter's two variants under one old name (re-exports; import from :mod:`simroad.filters`).

``"paper"``: :mod:`simroad.filters.highlights` (dark channel, eq. 27);
``"improved"``: :mod:`simroad.filters.glare` (additive lobe subtraction).
"""

from __future__ import annotations

from simroad.filters.glare import remove_glare
from simroad.filters.highlights import dark_channel, remove_highlights, specular_to_diffuse

__all__ = ["dark_channel", "remove_glare", "remove_highlights", "specular_to_diffuse"]
