"""The road's sheen: the sky it reflects at grazing angles.

Asphalt is not Lambertian. The binder on the tops of the aggregate is smooth, and
seen at the grazing angles of a driver's view (1-10 degrees below the horizontal a
few tens of metres ahead) it reflects the sky: roads brighten and take the sky's
colour towards the horizon (the road-lighting literature's specular factor of the
CIE r-tables, CIE 144:2001, rises from 0.3 for diffuse to 1.5 for specular
surfaces). The model here is the Fresnel reflectance of bitumen (n = 1.5, Schlick's
approximation) at the view's angle of incidence, times the sky radiance in the
mirror direction, times a per-world gloss ``k`` for the share of the surface that is
smooth binder (:attr:`simroad.camera.palette.Palette.sheen`):

``L = L_diffuse + k F(theta) L_sky(mirror)``,  ``F = F0 + (1 - F0) (1 - cos theta)^5``

(in a street canyon only the share ``sky_view`` of the mirror directions sees sky).

with ``cos theta`` the sine of the view's depression angle. The map
``F L_sky(mirror)`` depends only on the camera's mounting and the world's sky, so it is
computed once per episode; adding it to the road's pixels is one compiled pass over
the ground rows (in linear radiance, from and back to sRGB by table lookups).
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.camera.sky import SkySpec, camera_directions, sky_image, sky_radiance
from simroad.core.radiometry import DECODE_TABLE, GAMMA

__all__ = ["ENCODE_TABLE", "FRESNEL_F0", "add_sheen", "renderer_sheen", "renderer_sky", "sheen_map"]

#: Normal-incidence reflectance of bitumen (refractive index about 1.5).
FRESNEL_F0 = 0.04
#: Linear radiance (4096 steps over [0, 1]) -> sRGB level: the sheen's encoding.
ENCODE_TABLE = np.minimum(np.rint(255.0 * (np.arange(4096) / 4095.0) ** (1.0 / GAMMA)), 255).astype(np.uint8)


def sheen_map(camera: PinholeCamera, sky: SkySpec, r0: int) -> np.ndarray:
    """``F(theta) L_sky(mirror)`` of the ground rows ``r0`` on: float32 (H - r0, W, 3),
    0 where a pixel sees no ground (heading 0, as the renderer's sky)."""
    d = camera_directions(camera, 0.0)[r0:]
    ground = camera.ground_valid[r0:]
    norm = np.linalg.norm(d, axis=-1)
    cos_theta = np.clip(-d[..., 2] / np.maximum(norm, 1e-12), 0.0, 1.0)  # view's incidence on the flat ground
    mirror = d.copy()
    mirror[..., 2] = np.abs(mirror[..., 2])
    lsky = sky_radiance(
        mirror,
        sun_azimuth=sky.sun.azimuth_deg,
        sun_elevation=sky.sun.elevation_deg,
        condition=sky.condition,
        sky_type=sky.cie_type,
        brightness=sky.brightness,
    )
    fresnel = FRESNEL_F0 + (1.0 - FRESNEL_F0) * (1.0 - cos_theta) ** 5
    # Between buildings the open sky is 1 / sky_view brighter than the ground's light
    # (in ``lsky``) but the road reflects mostly facades: a sky_view share of the mirror
    # directions see sky, and that sky is the open sky.
    out = (fresnel[..., None] * lsky * np.float32(sky.sky_view**2)).astype(np.float32)
    out[~ground] = 0.0
    return np.ascontiguousarray(out)


def renderer_sky(camera: PinholeCamera, sky: SkySpec) -> np.ndarray:
    """``sky_image(camera, sky, heading=0.0)`` (read-only), computed once for a mounting
    and a sky: a reset of a world seen before draws the same sky."""
    return _sky_image(camera.config, sky)


def renderer_sheen(camera: PinholeCamera, sky: SkySpec, r0: int) -> np.ndarray:
    """``sheen_map(camera, sky, r0)`` (read-only), computed once for a mounting and a sky."""
    return _sheen_map(camera.config, sky, int(r0))


# Keyed by the camera's config: neither image depends on the pose (heading 0). ~0.7 MB
# each at 320 x 180.
@functools.lru_cache(maxsize=8)
def _sky_image(config: CameraConfig, sky: SkySpec) -> np.ndarray:
    return _read_only(sky_image(PinholeCamera(config), sky, heading=0.0))


@functools.lru_cache(maxsize=8)
def _sheen_map(config: CameraConfig, sky: SkySpec, r0: int) -> np.ndarray:
    return _read_only(sheen_map(PinholeCamera(config), sky, r0))


def _read_only(image: np.ndarray) -> np.ndarray:
    image.setflags(write=False)
    return image


@njit(cache=True, nogil=True)
def _add(rgb, road, add, decode, encode):  # pragma: no cover - compiled
    h, w = road.shape
    top = rgb.shape[0] - h
    for y in range(h):
        for x in range(w):
            if road[y, x]:
                for c in range(3):
                    lin = decode[rgb[top + y, x, c]] + add[y, x, c]
                    i = int(lin * 4095.0 + 0.5)
                    rgb[top + y, x, c] = encode[min(i, 4095)]


def add_sheen(rgb: np.ndarray, road: np.ndarray, sheen: np.ndarray) -> None:
    """Add ``sheen`` (linear radiance, float32 (H - r0, W, 3): :func:`sheen_map` times
    the world's gloss, made once per episode) to the road pixels of the bottom rows of
    ``rgb`` (uint8 (H, W, 3), in place); ``road`` is bool (H - r0, W)."""
    _add(rgb, road, sheen, DECODE_TABLE, ENCODE_TABLE)
