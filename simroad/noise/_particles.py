"""The particles stage shared by rain and snow: a field of drops or flakes drawn as streaks.

The field (:mod:`simroad.noise._particle_field`) is drawn once per episode and moved
every frame; its streaks during the exposure are blended into the frame by eq. 19
(:mod:`simroad.noise._streaks`). The names of both modules are re-exported here.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np

from simroad.camera.geometry import CameraConfig
from simroad.noise._geometry import ViewGeometry, view_geometry
from simroad.noise._particle_field import (
    ParticleField,
    advance,
    wind_in_ego,
)
from simroad.noise._streaks import blend, splat_streaks, streaks
from simroad.noise.context import FrameState
from simroad.noise.model import Limit, NoiseModel

__all__ = [
    "PARTICLE_LIMITS",
    "ParticleModel",
]

PARTICLE_LIMITS: Mapping[str, Limit] = MappingProxyType(
    {
        "wind_m_s": Limit(0.0, 40.0, "m/s"),
        "wind_dir_deg": Limit(-360.0, 360.0, "degrees"),
        "exposure_s": Limit(0.0, 0.1, "s", low_inclusive=False),
        "max_particles": Limit(0, 200000, integer=True),
    }
)
"""Limits of the fields every particle model's params carry (rain's and snow's)."""


class ParticleModel(NoiseModel):
    """The ``particles`` stage shared by rain and snow.

    Subclasses provide ``_sample(geom) -> ParticleField``, ``_radiance(state)`` (the
    particles' linear RGB, (3,)) and ``_has_particles()``; their params carry
    ``wind_m_s``, ``wind_dir_deg``, ``exposure_s`` and ``max_particles``, limited by
    :data:`PARTICLE_LIMITS`. The field is drawn at the first
    frame (from the model's generator) and then advanced by ``ctx.dt`` every frame.
    """

    def _on_reset(self) -> None:
        self.field: ParticleField | None = None
        self._field_config: CameraConfig | None = None

    def _sample(self, geom: ViewGeometry) -> ParticleField:  # pragma: no cover - abstract
        raise NotImplementedError

    def _radiance(self, state: FrameState) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _has_particles(self) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def particles(self, state: FrameState) -> None:
        if not self._has_particles():
            return
        p, ctx = self.params, state.ctx
        geom = view_geometry(state.camera)
        wind = wind_in_ego(p.wind_m_s, p.wind_dir_deg, state.camera.pose[2])
        speed, yaw_rate = ctx.ego_speed, ctx.ego_yaw_rate
        if self.field is None or self._field_config != geom.config:
            self.field = self._sample(geom)
            self._field_config = geom.config
        else:
            advance(
                self.field,
                ctx.dt,
                wind_ego=wind,
                speed=speed,
                yaw_rate=yaw_rate,
                forward_m=geom.forward_m,
                time_s=ctx.time_s,
            )
        seg = streaks(
            self.field, geom, wind_ego=wind, speed=speed, yaw_rate=yaw_rate, exposure_s=p.exposure_s, time_s=ctx.time_s
        )
        blend(state.lin, splat_streaks(*seg, state.shape), self._radiance(state))
