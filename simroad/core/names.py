"""The names every package refers to things by, stated once.

The models, filters and scenarios themselves are registered where they live
(:data:`simroad.noise.MODELS`, :data:`simroad.filters.FILTER_REGISTRY`,
:data:`simroad.envs.SCENARIOS`); the names here are what the layers below them
(filters, detector, metrics) and the command line need without importing them.
"""

from __future__ import annotations

__all__ = ["HELD_OUT_SEEDS", "NOISE_NAMES", "PROFILES", "TRAIN_SEEDS"]

#: Weather conditions, in the order tables and figures list them. ``clear`` is no
#: weather; the others name a noise model of :mod:`simroad.noise`.
NOISE_NAMES = ("clear", "rain", "snow", "shadow", "glare", "fog")

#: Ground profiles beside the road: verges (``rural``) or kerb and sidewalk (``urban``).
PROFILES = ("rural", "urban")

#: Seed splits. Worlds (episode seeds) the shipped model was trained on ...
TRAIN_SEEDS = tuple(range(16))
#: ... and worlds it never saw: the default of detector evaluations (evaluation
#: worlds are seeds >= 100; validation and the paper's experiment use their own ranges,
#: see ``experiments/*.toml``).
HELD_OUT_SEEDS = tuple(range(100, 105))
