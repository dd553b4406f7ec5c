"""The sky when the sun comes out: the clear CIE sky of the noise models' sun.

Clear weather in simroad is overcast (:mod:`simroad.camera.lighting`); the shadow and
glare models bring out the sun, and with it the sky turns clear: blue away from the
sun, whitish towards it and at the horizon (:func:`simroad.camera.sky.sky_radiance`,
CIE standard general sky type 12). The clear sky's radiance is in the frame's units
(the lit horizontal ground's irradiance maps to ``NOMINAL_EXPOSURE``), so sky, road
and shadows share one sun.

A panorama of the clear sky (world azimuth x elevation, 0.5 degrees) is computed
once per sun; each frame samples it with one ``cv2.remap`` along every sky pixel's
direction for the camera's heading.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from simroad.camera.codes import SKY
from simroad.camera.geometry import PinholeCamera
from simroad.camera.sky import camera_directions, sky_radiance
from simroad.noise.context import FrameState

__all__ = ["CLEAR_SKY_RATIO", "clear_sky", "clear_sky_panorama"]

#: Direct-to-sky irradiance ratio E_sun/E_sky at and above which the sky is fully
#: clear (clear days: 3-9); below it the sky is partly clear in proportion.
CLEAR_SKY_RATIO = 5.0

_STEP_DEG = 0.5
_EL_MIN_DEG = -2.0


@functools.lru_cache(maxsize=8)
def clear_sky_panorama(sun_azimuth_deg: float, sun_elevation_deg: float) -> np.ndarray:
    """Clear-sky linear radiance, float32 (elevations, azimuths, 3): row ``i`` at
    elevation ``-2 + 0.5 i`` degrees, column ``j`` at world azimuth ``0.5 j`` degrees."""
    el = np.radians(np.arange(_EL_MIN_DEG, 90.0 + _STEP_DEG, _STEP_DEG))
    az = np.radians(np.arange(0.0, 360.0, _STEP_DEG))
    E, A = np.meshgrid(el, az, indexing="ij")
    d = np.stack([np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E)], axis=-1)
    pano = sky_radiance(d, sun_azimuth=sun_azimuth_deg, sun_elevation=sun_elevation_deg, condition="clear")
    pano.flags.writeable = False
    return pano


def _pixel_angles(camera: PinholeCamera) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel: world azimuth at heading 0 and elevation, both in panorama cells."""
    key = "_sunny_sky_angles"
    hit = camera.__dict__.get(key)
    if hit is None:
        d = camera_directions(camera, heading=0.0)
        az = np.degrees(np.arctan2(d[..., 1], d[..., 0])) % 360.0
        el = np.degrees(np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1])))
        hit = ((az / _STEP_DEG).astype(np.float32), ((el - _EL_MIN_DEG) / _STEP_DEG).astype(np.float32))
        camera.__dict__[key] = hit
    return hit


def clear_sky(state: FrameState, sun: tuple[float, float], weight: float) -> None:
    """Blend the sky pixels of ``state`` towards the clear sky of ``sun``.

    ``sun = (azimuth, elevation)`` in radians (world heading of the sun); ``weight``
    in [0, 1] is how far the sky has cleared (0: unchanged). Models that share the
    sun (``shadow+glare``) clear it once: the larger weight wins. The cleared
    pixels are marked in ``state.unmasked``: they stay out of the noise masks.
    """
    done = state.sky_clear
    weight = float(min(max(weight, 0.0), 1.0))
    if weight <= done + 1e-6:
        return
    sky = state.material == SKY if state.material is not None else ~np.isfinite(state.depth)
    rows = np.flatnonzero(sky.any(axis=1))
    if not len(rows):
        state.sky_clear = weight
        return
    r = slice(0, int(rows[-1]) + 1)
    az_px, el_px = _pixel_angles(state.camera)
    pano = clear_sky_panorama(round(math.degrees(sun[0]) % 360.0, 2), round(math.degrees(sun[1]), 2))
    mapx = az_px[r] + np.float32((math.degrees(state.camera.pose[2]) % 360.0) / _STEP_DEG)
    turn = np.float32(pano.shape[1])
    for _ in range(2):  # mapx %= turn for the sums in [0, 2 turns] (exact: x - turn), 20x faster
        np.subtract(mapx, turn, out=mapx, where=mapx >= turn)
    clear = cv2.remap(pano, mapx, el_px[r], cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    w = np.float32((weight - done) / (1.0 - done))  # the increment over what is already clear
    band = state.lin[r]
    m = sky[r]
    # band[m] += w * (clear[m] - band[m]), the same float32 arithmetic without the boolean
    # gathers and scatter (15x faster on a 320x180 frame's sky)
    np.subtract(clear, band, out=clear)
    np.multiply(clear, w, out=clear)
    np.add(band, clear, out=band, where=m[..., None])
    state.sky_clear = weight
    if state.unmasked is None:
        state.unmasked = np.zeros(state.shape, dtype=bool)
    state.unmasked[r] |= m
