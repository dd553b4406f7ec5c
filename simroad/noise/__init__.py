"""Environmental noise from physical models: rain, snow, shadow, glare and fog.

World-consistent (shadows stay on the ground, glare follows the sun as the car
turns), temporally coherent (drops fall from frame to frame), and with a ground-truth
mask of where each noise changed the picture by at least 8 grey levels.

>>> from simroad.noise import make_weather, NoiseContext
>>> weather = make_weather("rain+glare", severity=0.7)
>>> weather.reset(rng, world=world)                                  # doctest: +SKIP
>>> noisy, masks = weather.apply(frame.rgb, NoiseContext(camera=cam, depth=frame.depth,
...     material=frame.material, vehicles=frame.vehicles, ego_speed=20.0))  # doctest: +SKIP

Severity -> physical parameters (s in [0, 1]; 0 leaves the frame unchanged)

=======  ====================================================================
noise    parameters
=======  ====================================================================
rain     rate 100·s² mm/h (Marshall–Palmer drops 0.5–7 mm, Gunn–Kinzer speeds),
         wind 8·s m/s, soaked min(1, 2s), water film 0.6·s², exposure 1/500 s;
         haze from the drops (visibility 1.4 km at s=0.5, 590 m at s=1)
snow     3000·s^1.5 flakes/m³ of 1–5 mm at 0.5–2 m/s, wind 6·s m/s, flutter
         0.4 m/s, exposure 1/500 s; settled cover 0.9·clip(2s − 1, 0, 1) on
         roadside and shoulders; haze (visibility 450 m at s=0.5, 160 m at s=1)
shadow   the sun at 120° azimuth, 60 − 40·s degrees, E_sun/E_sky = s·(8, 6, 3);
         every object of the world, vehicle and the ego casts its shadow
glare    sun 0° azimuth (ahead on highway-env's straights) at 21 − 16·s degrees,
         E_sun/E_sky 6, dry roughness 0.35, wetness 0.5·s, veil 0.5 + 2.5·s deg²
fog      visibility 2000·(30/2000)^s m (β_ext = 3.912/visibility), airlight 0.7
=======  ====================================================================

Rain and snow also wet the windscreen (``windscreen=True`` by default; mask
``"windscreen"``): adherent drops collected at the rain's rate and the car's speed,
each a defocused water lens, and a wiper (:mod:`simroad.noise.windscreen`).

See ``docs/weather.md`` for the physics and the references.
"""

from __future__ import annotations

from simroad.noise._windscreen_params import WIPER_MODES, WindscreenParams
from simroad.noise.compose import (
    MODELS,
    NoiseParams,
    Weather,
    apply_noise,
    check_noise_params,
    make_weather,
    parse_noise,
    windscreen_model,
)
from simroad.noise.context import NoiseContext, flat_ground_camera
from simroad.noise.fog import FogModel, FogParams
from simroad.noise.glare import GlareModel, GlareParams
from simroad.noise.model import STAGES, Limit, NoiseModel, NoiseResult, Params
from simroad.noise.rain import RainModel, RainParams
from simroad.noise.shadow import ShadowModel, ShadowParams
from simroad.noise.snow import SnowModel, SnowParams
from simroad.noise.windscreen import WindscreenModel

__all__ = [
    "MODELS",
    "STAGES",
    "WIPER_MODES",
    "FogModel",
    "FogParams",
    "GlareModel",
    "GlareParams",
    "Limit",
    "NoiseContext",
    "NoiseModel",
    "NoiseParams",
    "NoiseResult",
    "Params",
    "RainModel",
    "RainParams",
    "ShadowModel",
    "ShadowParams",
    "SnowModel",
    "SnowParams",
    "Weather",
    "WindscreenModel",
    "WindscreenParams",
    "apply_noise",
    "check_noise_params",
    "flat_ground_camera",
    "make_weather",
    "parse_noise",
    "windscreen_model",
]
