"""The world's light: how albedo becomes linear radiance in the rendered frame.

Clear weather in simroad is a bright overcast day: diffuse light from the whole sky,
no direct sun, so no cast shadows (the shadow noise brings the sun out and casts the
shadows of what stands in the world). Linear pixel values are
``NOMINAL_EXPOSURE * albedo * E(n)``, with ``E`` the irradiance relative to that of a
horizontal surface under the unoccluded sky:

``E(n) = (1 + n_z) / 2 + ground_albedo * (1 - n_z) / 2``

(the sky-view and ground-view factors of a plane with unit normal ``n``). A perfect
white horizontal surface maps to ``NOMINAL_EXPOSURE``; values above 1 clip at white.
The frame is encoded with the project's gamma (:mod:`simroad.core.radiometry`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["NOMINAL_EXPOSURE", "face_irradiance", "radiance"]

#: Linear value of a perfect white horizontal surface in clear (overcast) weather:
#: aged asphalt (albedo ~0.12) comes out near sRGB 100, concrete (~0.3) near 150.
NOMINAL_EXPOSURE = 0.5


def face_irradiance(normal_z: np.ndarray | float, ground_albedo: float = 0.15) -> np.ndarray:
    """Diffuse irradiance of a plane with normal z-component ``normal_z`` relative to
    a horizontal plane (sky-view factor plus ground-reflected light)."""
    nz = np.asarray(normal_z, dtype=np.float32)
    return (1.0 + nz) / 2.0 + np.float32(ground_albedo) * (1.0 - nz) / 2.0


def radiance(albedo: np.ndarray, normal_z: np.ndarray | float = 1.0, ground_albedo: float = 0.15) -> np.ndarray:
    """Linear radiance (float32, ``albedo``'s shape) of Lambertian surfaces."""
    e = face_irradiance(normal_z, ground_albedo)
    a = np.asarray(albedo, dtype=np.float32)
    if e.ndim:
        e = e[..., None]
    return (np.float32(NOMINAL_EXPOSURE) * a * e).astype(np.float32)
