"""The windscreen's per-frame pass: every drop's sprite composited over the frame, compiled.

One loop over the drops and their sprites' pixels (numba, ``cache=True``; the first
call of a fresh install compiles for a few seconds and writes the cache next to this
module). Each drop covers a fraction ``α`` of the lens's aperture at each of its pixels
and is composited over what is behind it, in order of arrival:
``I ← (1 − α)·I + w·scene + (α − w)·rim·mean``, where ``w ≤ α`` is the part of the drop
that carries the refracted scene (a bilinear sample of the reduced frame at the pixel's
source, clamped at the border; for a drop drawn in one colour, a tiny one, its mean
view: one sample of the widely averaged frame at its centre) and ``α − w`` its totally
reflecting rim, which shows ``rim`` times its mean view. Overlapping drops thus share the
aperture as independent occluders (the covered fractions multiply), and the coverage
never passes 1. The loop runs in drop order without fast-math, so the result is the
same whether the kernel was just compiled or loaded from the cache.
:func:`simroad.noise._drops.draw_drops_reference` is the numpy reference the tests hold
it to.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["COVERED", "advance_drops", "splat_drops"]

#: A pixel is in the windscreen's mask where a drop covers at least this fraction of the
#: lens's aperture (a tenth of its light comes from the drop: about where a drop's
#: change of the picture becomes noticeable at ordinary contrast).
COVERED = 0.1


@njit(cache=True, nogil=True)
def _bilinear(image: np.ndarray, x: np.float32, y: np.float32) -> tuple[float, float, float]:
    """``image`` (h, w, 3) at ``(x, y)``: bilinear, float32, the border replicated."""
    h, w = image.shape[0], image.shape[1]
    sx = min(max(x, np.float32(0.0)), np.float32(w - 1))
    sy = min(max(y, np.float32(0.0)), np.float32(h - 1))
    x0, y0 = int(sx), int(sy)
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = sx - np.float32(x0), sy - np.float32(y0)
    gx, gy = np.float32(1.0) - fx, np.float32(1.0) - fy
    w00, w01, w10, w11 = gx * gy, fx * gy, gx * fy, fx * fy
    r = image[y0, x0, 0] * w00 + image[y0, x1, 0] * w01 + image[y1, x0, 0] * w10 + image[y1, x1, 0] * w11
    g = image[y0, x0, 1] * w00 + image[y0, x1, 1] * w01 + image[y1, x0, 1] * w10 + image[y1, x1, 1] * w11
    b = image[y0, x0, 2] * w00 + image[y0, x1, 2] * w01 + image[y1, x0, 2] * w10 + image[y1, x1, 2] * w11
    return r, g, b


@njit(cache=True, nogil=True)
def splat_drops(
    lin: np.ndarray,
    small: np.ndarray,
    wide: np.ndarray,
    factor: int,
    drops: tuple[np.ndarray, np.ndarray, np.ndarray],
    bank: tuple[np.ndarray, ...],
    rim: float,
    covered: np.ndarray,
    touched: np.ndarray,
) -> None:
    """Composite the drops over ``lin`` in place, one after the other.

    Parameters
    ----------
    lin : ndarray float32 (H, W, 3)
        The linear frame (C-contiguous).
    small, wide : ndarray float32 (h, w, 3)
        The frame reduced by ``factor``, and that further averaged over a drop's field
        of view (:func:`simroad.noise._drops.scene_low_pass`).
    drops : tuple
        ``(u, v, sprite)``: centre pixel (int32) and sprite id (int32, -1: not drawn).
    bank : tuple
        ``(start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv)`` of the
        sprite bank (see :class:`simroad.noise._drops.SpriteBank`).
    rim : float
        What a drop's totally reflecting rim shows, as a fraction of its mean view.
    covered : ndarray bool (H·W,)
        Set where a drop covers at least :data:`COVERED` of the aperture (others left
        as they are).
    touched : ndarray bool (H·W,)
        Set at every pixel written (others left as they are).
    """
    u, v, sprite = drops
    start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv = bank
    height, width = lin.shape[0], lin.shape[1]
    inv, half, rim32 = np.float32(1.0 / factor), np.float32(0.5), np.float32(rim)
    one, cover_min = np.float32(1.0), np.float32(COVERED)
    for d in range(u.size):
        s = sprite[d]
        if s < 0:
            continue
        cx = (np.float32(u[d]) + half) * inv - half
        cy = (np.float32(v[d]) + half) * inv - half
        one_colour = uniform[s] != 0
        mr, mg, mb = _bilinear(wide, cx, cy)  # the drop's whole view, averaged
        dr, dg, db = mr * rim32, mg * rim32, mb * rim32  # what its totally reflecting rim shows
        r, g, b = mr, mg, mb
        for i in range(start[s], start[s] + length[s]):
            x, y = u[d] + du[i], v[d] + dv[i]
            if x < 0 or x >= width or y < 0 or y >= height:
                continue
            a, ws = alpha[i], w_scene[i]
            keep, wr = one - a, a - ws
            touched[y * width + x] = True
            if a >= cover_min:
                covered[y * width + x] = True
            if not one_colour:
                r, g, b = _bilinear(small, cx + src_du[i] * inv, cy + src_dv[i] * inv)
            lin[y, x, 0] = lin[y, x, 0] * keep + ws * r + wr * dr
            lin[y, x, 1] = lin[y, x, 1] * keep + ws * g + wr * dg
            lin[y, x, 2] = lin[y, x, 2] * keep + ws * b + wr * db


@njit(cache=True, nogil=True)
def advance_drops(
    gx: np.ndarray,
    gy: np.ndarray,
    velocity: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    dt: float,
    project: np.ndarray,
    size: tuple[int, int],
    wiper: tuple[float, float, float],
    swept: np.ndarray,
) -> np.ndarray:
    """One frame of the drops' motion and of the wiper, in one pass (in place).

    Each drop with a non-zero ``velocity`` (m/s up the glass) moves by ``velocity·dt``
    and is projected again (``u``, ``v``: the nearest pixel); it is gone if its centre
    left the image. A drop within the blade's reach whose angle about the pivot lies
    in one of the ``swept`` intervals is gone too.

    Parameters
    ----------
    gx, gy : ndarray float64
        Glass coordinates, m (``gy`` is updated).
    velocity : ndarray float64
        Velocity along the glass, m/s.
    u, v : ndarray int32
        Image pixels of the drops (updated for the moving ones).
    dt : float
        Frame interval, s.
    project : ndarray float64 (3, 3)
        Columns: the homogeneous image point of the glass origin, and its change per
        metre of ``gx`` and of ``gy``.
    size : tuple
        Image ``(width, height)``, px.
    wiper : tuple
        Pivot ``(x, y)`` on the glass, m, and the blade's length, m.
    swept : ndarray float64 (k, 2)
        Blade angles ``[lo, hi]`` swept during the frame (radians; none: no wipe).

    Returns
    -------
    ndarray bool
        The drops still on the glass and in view.
    """
    width, height = size
    px, py, reach = wiper
    alive = np.ones(gx.size, np.bool_)
    for d in range(gx.size):
        if velocity[d] != 0.0:
            gy[d] += velocity[d] * dt
            cx = project[0, 0] + project[0, 1] * gx[d] + project[0, 2] * gy[d]
            cy = project[1, 0] + project[1, 1] * gx[d] + project[1, 2] * gy[d]
            cz = project[2, 0] + project[2, 1] * gx[d] + project[2, 2] * gy[d]
            x, y = cx / cz, cy / cz
            if x < -0.5 or x > width - 0.5 or y < -0.5 or y > height - 0.5:
                alive[d] = False
                continue
            u[d] = min(max(np.rint(x), 0.0), width - 1.0)
            v[d] = min(max(np.rint(y), 0.0), height - 1.0)
        if swept.shape[0] > 0:
            rx, ry = gx[d] - px, gy[d] - py
            if math.hypot(ry, rx) <= reach:
                angle = math.atan2(ry, rx)
                for k in range(swept.shape[0]):
                    if swept[k, 0] <= angle <= swept[k, 1]:
                        alive[d] = False
                        break
    return alive
