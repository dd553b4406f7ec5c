"""Fog: Koschmieder's law of atmospheric extinction over the depth map.

A surface of radiance J seen through a homogeneous scattering atmosphere at distance
d arrives as ``I = J·t + A·(1 − t)``, ``t = exp(−β_ext·d)``, with A the airlight
(the radiance of an infinitely deep column of the medium, i.e. the horizon sky in
fog). The meteorological visibility V is the distance at which a black object's
contrast against the horizon falls to 2 % (Koschmieder), hence
``β_ext = −ln(0.02) / V = 3.912 / V``.

Distances come from the frame's depth map (ground distance; it differs from the
3-D range by less than 1 % beyond 10 m for a 1.3 m camera). The sky has infinite
depth; it is seen through the fog layer only, of thickness ``sky_path_m``.

Severity mapping (:meth:`FogParams.from_severity`), s in (0, 1]::

    visibility_m = 2000 · (30 / 2000) ** s      # 2 km (haze) … 245 m (s=0.5) … 30 m (dense fog)
    airlight     = 0.7 (linear, grey)           # overcast brightness, 0.7 ≈ 216/255 encoded

s = 0 is no fog (the frame is returned unchanged).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np

from simroad.core.validation import check_in_range
from simroad.noise._arrays import fast_exp, gray3, rgb_scalar
from simroad.noise.context import FrameState
from simroad.noise.model import Limit, NoiseModel, Params

__all__ = ["FogModel", "FogParams", "extinction_from_visibility", "koschmieder"]

KOSCHMIEDER_CONSTANT = 3.912  # -ln(0.02)


def extinction_from_visibility(visibility_m: float) -> float:
    """Extinction coefficient β_ext in 1/m for a meteorological visibility in m."""
    return KOSCHMIEDER_CONSTANT / visibility_m


def koschmieder(
    lin: np.ndarray,
    depth: np.ndarray,
    beta_ext: float,
    airlight: np.ndarray | float,
    *,
    sky_path_m: float = 1000.0,
) -> None:
    """Apply ``I = J·t + A·(1 − t)``, ``t = exp(−β_ext·d)`` in place.

    Parameters
    ----------
    lin : ndarray float32 (H, W, 3)
        Linear radiance J, overwritten with I.
    depth : ndarray float32 (H, W)
        Distance d in m; ``inf`` is replaced by ``sky_path_m``.
    beta_ext : float
        Extinction coefficient in 1/m.
    airlight : float or ndarray (3,)
        Airlight A in linear radiance.
    sky_path_m : float
        Path length through the medium for pixels of infinite depth, m.
    """
    d = np.minimum(depth, np.float32(sky_path_m))
    t = fast_exp(d * np.float32(-beta_ext))
    a = rgb_scalar(airlight)
    cv2.subtract(lin, a, dst=lin)  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands
    lin *= gray3(t)
    cv2.add(lin, a, dst=lin)  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands


@dataclass(frozen=True)
class FogParams(Params):
    """Physical parameters of fog.

    Parameters
    ----------
    visibility_m : float
        Meteorological visibility in m; ``inf``-like values (>= 1e6) mean no fog.
    airlight : float
        Airlight (horizon radiance in fog), linear relative radiance.
    sky_path_m : float
        Depth of fog the sky is seen through, m.
    layer_m : float
        Thickness of the fog layer above the road for the sun's attenuation, m.

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "visibility_m": Limit(10.0, 1e6, "m"),
        "airlight": Limit(0.0, 1.0),
        "sky_path_m": Limit(10.0, 1e5, "m"),
        "layer_m": Limit(0.0, 1e4, "m"),
    }

    visibility_m: float = 200.0
    airlight: float = 0.7
    sky_path_m: float = 1000.0
    layer_m: float = 100.0

    @classmethod
    def from_severity(cls, severity: float) -> FogParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        if s == 0.0:
            return cls(visibility_m=1e6)
        return cls(visibility_m=2000.0 * (30.0 / 2000.0) ** s)

    @property
    def beta_ext(self) -> float:
        """Extinction coefficient in 1/m."""
        return extinction_from_visibility(self.visibility_m)

    @property
    def is_identity(self) -> bool:
        return self.visibility_m >= 1e6


class FogModel(NoiseModel):
    """Koschmieder fog over the depth map; dims the sun for the other models."""

    name = "fog"
    params_type = FogParams
    stages = ("atmosphere",)

    def prepare(self, state: FrameState) -> None:
        state.sun_optical_depth += self.params.beta_ext * self.params.layer_m

    def atmosphere(self, state: FrameState) -> None:
        p = self.params
        koschmieder(state.lin, state.depth, p.beta_ext, p.airlight, sky_path_m=p.sky_path_m)
