"""The windscreen's per-frame pass: every drop's sprite splatted and blended, compiled.

One loop over the drops and their sprites' pixels (numba, ``cache=True``; the first
call of a fresh install compiles for a few seconds and writes the cache next to this
module). For each drop pixel it adds the defocused coverage, the part of it that
carries the refracted scene, and that scene into an accumulator: a bilinear sample
of the low-passed frame at the pixel's source (clamped at the border), or, for a
drop drawn in one colour (a tiny one), its mean view: one sample of the widely
averaged frame at the drop's centre; the rest of its coverage, the totally reflecting
rim, shows ``rim`` times that mean view. Then it blends the touched pixels:
``(1 − A)·background + Σ w_scene·scene + Σ(alpha − w_scene)·rim·mean``, the drop terms
scaled by ``1/A`` where the summed coverage ``A`` passes 1. The sums run in drop
order without fast-math, so the result is the same whether the kernel was just
compiled or loaded from the cache. :func:`simroad.noise._drops.draw_drops_reference`
is the numpy reference the tests hold it to.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["COVERED", "splat_drops"]

#: A pixel is in the windscreen's mask where drops cover at least this fraction of the
#: lens's aperture (a tenth of its light comes from the glass: about where a drop's
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
def _blend(lin: np.ndarray, acc: np.ndarray, touched: np.ndarray, count: int, covered: np.ndarray) -> None:
    """Blend the accumulated drops into the touched pixels, mark those the drops cover
    at least :data:`COVERED` of, and zero their accumulators."""
    width = lin.shape[1]
    one, cover_min = np.float32(1.0), np.float32(COVERED)
    for k in range(count):
        p = touched[k]
        y = p // width
        x = p - y * width
        a = acc[p, 0]
        covered[p] = a >= cover_min
        scale = one / max(a, one)
        keep = one - a * scale
        for c in range(3):
            lin[y, x, c] = lin[y, x, c] * keep + acc[p, 1 + c] * scale
        for j in range(4):
            acc[p, j] = 0.0


@njit(cache=True, nogil=True)
def splat_drops(
    lin: np.ndarray,
    small: np.ndarray,
    wide: np.ndarray,
    factor: int,
    drops: tuple[np.ndarray, np.ndarray, np.ndarray],
    bank: tuple[np.ndarray, ...],
    rim: float,
    acc: np.ndarray,
    touched: np.ndarray,
    covered: np.ndarray,
) -> int:
    """Blend the drops into ``lin`` in place; returns the number of pixels touched.

    Parameters
    ----------
    lin : ndarray float32 (H, W, 3)
        The linear frame (C-contiguous).
    small, wide : ndarray float32 (h, w, 3)
        The frame averaged over ``factor`` x ``factor`` blocks, and that further
        averaged over a drop's field of view.
    drops : tuple
        ``(u, v, sprite)``: centre pixel (int32) and sprite id (int32, -1: not drawn).
    bank : tuple
        ``(start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv)`` of the
        sprite bank (see :class:`simroad.noise._drops.SpriteBank`).
    rim : float
        What a drop's totally reflecting rim shows, as a fraction of its mean view.
    acc : ndarray float32 (H·W, 4)
        Zeros on entry; left zero on return.
    touched : ndarray int32 (H·W,)
        Scratch.
    covered : ndarray bool (H·W,)
        Set where the drops' summed coverage is at least :data:`COVERED` (others left
        as they are).
    """
    u, v, sprite = drops
    start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv = bank
    height, width = lin.shape[0], lin.shape[1]
    inv, half, rim32 = np.float32(1.0 / factor), np.float32(0.5), np.float32(rim)
    n_touched = 0
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
            p = y * width + x
            if acc[p, 0] == 0.0:
                touched[n_touched] = p
                n_touched += 1
            ws = w_scene[i]
            wr = alpha[i] - ws
            acc[p, 0] += alpha[i]
            if not one_colour:
                r, g, b = _bilinear(small, cx + src_du[i] * inv, cy + src_dv[i] * inv)
            acc[p, 1] += ws * r + wr * dr
            acc[p, 2] += ws * g + wr * dg
            acc[p, 3] += ws * b + wr * db
    _blend(lin, acc, touched, n_touched, covered)
    return n_touched
