"""Old home of the weather models' shared machinery, kept so its imports still work.

The machinery now lives in modules that each do one job:

- :mod:`simroad.noise.radiometry` — sRGB <-> linear radiance, the change mask;
- :mod:`simroad.noise.context` — :class:`NoiseContext` and :class:`FrameState`;
- :mod:`simroad.noise.model` — :class:`Params`, :class:`NoiseModel`, :func:`run_models`;
- :mod:`simroad.noise._arrays` and :mod:`simroad.noise._geometry` — small helpers.
"""

from __future__ import annotations

from simroad.noise._arrays import fast_exp, gray3, material_weights, rgb_scalar, smoothstep
from simroad.noise._geometry import sun_direction_ego
from simroad.noise.context import FrameState, NoiseContext, flat_ground_camera
from simroad.noise.model import STAGES, Limit, NoiseModel, NoiseResult, Params, run_models
from simroad.noise.radiometry import GAMMA, MASK_THRESHOLD, change_mask, linear_to_srgb, srgb_to_linear

__all__ = [
    "GAMMA",
    "MASK_THRESHOLD",
    "STAGES",
    "FrameState",
    "Limit",
    "NoiseContext",
    "NoiseModel",
    "NoiseResult",
    "Params",
    "change_mask",
    "fast_exp",
    "flat_ground_camera",
    "gray3",
    "linear_to_srgb",
    "material_weights",
    "rgb_scalar",
    "run_models",
    "smoothstep",
    "srgb_to_linear",
    "sun_direction_ego",
]
