"""The names every package refers to things by, stated once.

The models, filters and scenarios themselves are registered where they live
(:data:`simroad.noise.MODELS`, :data:`simroad.filters.FILTER_REGISTRY`,
:data:`simroad.envs.SCENARIOS`); the names here are what the layers below them
(filters, detector, metrics) and the command line need without importing them.
"""

from __future__ import annotations

__all__ = ["NOISE_NAMES", "PROFILES"]

#: Weather conditions, in the order tables and figures list them. ``clear`` is no
#: weather; the others name a noise model of :mod:`simroad.noise`.
NOISE_NAMES = ("clear", "rain", "snow", "shadow", "glare", "fog")

#: Ground profiles beside the road: verges (``rural``) or kerb and sidewalk (``urban``).
PROFILES = ("rural", "urban")
