"""The world raster's tile composition, compiled: textures, asphalt wear, paint, road SDF.

One pass over a tile's texels (numba, ``cache=True``) doing what numpy's masked array
operations did, with the same float32 operations in the same order (no fast-math),
so the tiles are the same to the bit (see :meth:`simroad.camera.world.WorldRaster._render_tile`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simroad.camera.codes import ASPHALT, MARKING, ROADSIDE

__all__ = ["compose_tile"]


@njit(cache=True, nogil=True)
def compose_tile(material, sdf, paint, cover, textures, slot, ti, tj, wear_lut, wear_res, rgba):  # pragma: no cover
    """Compose one tile in place.

    Parameters
    ----------
    material : ndarray uint8 (T, T)
        Ground material of every texel (from the SDF's bands); set to ``MARKING``
        where ``paint`` is on the road (``sdf >= 0``).
    sdf : ndarray float32 (T, T)
        Signed distance to the road surface (m).
    paint, cover : ndarray uint8 (T, T)
        Painted markings (any > 0) and their anti-aliased coverage (0-255).
    textures : ndarray uint8 (K, S, S, 3)
        The ground textures, ``slot[code]`` the one of material ``code`` (-1: none,
        the roadside's is used).
    ti, tj : int
        Row and column of the tile in the textures.
    wear_lut : ndarray float32 (N,)
        Asphalt wear factor per ``wear_res`` steps per metre inside the road.
    rgba : ndarray uint8 (T, T, 4)
        Out: the colour under the paint (paint asphalt-coloured where worn), the
        paint over it by its coverage, and ``128 + 254 * sdf`` rounded and clipped.
    """
    T = material.shape[0]
    steps = wear_lut.shape[0]
    roadside, marking = slot[ROADSIDE], slot[MARKING]
    for r in range(T):
        for c in range(T):
            d = sdf[r, c]
            if paint[r, c] > 0 and d >= 0.0:
                material[r, c] = MARKING
            under = ASPHALT if material[r, c] == MARKING else material[r, c]
            k = slot[under]
            k = roadside if k < 0 or under == ROADSIDE or under == MARKING else k
            px = textures[k, ti + r, tj + c]
            v0, v1, v2 = px[0], px[1], px[2]
            if under == ASPHALT:
                f = wear_lut[min(np.int32(d * np.float32(wear_res)), steps - 1)]
                v0, v1, v2 = _wear(v0, f), _wear(v1, f), _wear(v2, f)
            if cover[r, c] > 0:
                a = np.float32(cover[r, c]) / np.float32(255.0)
                mark = textures[marking, ti + r, tj + c]
                v0, v1, v2 = _over(v0, mark[0], a), _over(v1, mark[1], a), _over(v2, mark[2], a)
            rgba[r, c, 0], rgba[r, c, 1], rgba[r, c, 2] = v0, v1, v2
            s = np.rint(np.float32(128.0) + np.float32(254.0) * d)
            rgba[r, c, 3] = np.uint8(min(max(s, np.float32(0.0)), np.float32(255.0)))


@njit(cache=True, nogil=True, inline="always")
def _wear(v, f):  # pragma: no cover - compiled
    """``clip(v * f, 0, 255)`` in float32, truncated to uint8."""
    x = np.float32(v) * f
    return np.uint8(min(max(x, np.float32(0.0)), np.float32(255.0)))


@njit(cache=True, nogil=True, inline="always")
def _over(v, m, a):  # pragma: no cover - compiled
    """``clip(v + a (m - v), 0, 255)`` in float32, truncated to uint8."""
    base = np.float32(v)
    x = base + a * (np.float32(m) - base)
    return np.uint8(min(max(x, np.float32(0.0)), np.float32(255.0)))
