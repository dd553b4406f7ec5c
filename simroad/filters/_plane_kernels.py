"""Compiled loops over whole float32 planes that the filter pipeline runs on every frame, numba ``cache=True``.

Each is bit for bit the numpy or OpenCV call it replaces (:mod:`tests.filters.test_kernels`
holds them to it), two to three times faster at 1280x720: the clip after a filter
(``np.clip``) and the fourfold reduction of the weather gates' preview (``cv2.resize``,
``INTER_AREA``); and the least-squares non-decreasing fit of a short profile (the haze
gate's row floor), which ``scipy.optimize.isotonic_regression`` also computes (to the
last bits; tests hold it to it) but whose import alone costs more than all the filters.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["area_quarter", "clip_unit", "isotonic_increasing"]


@njit(cache=True, nogil=True)
def clip_unit(p: np.ndarray) -> None:
    """``np.clip(p, 0, 1, out=p)`` of a C-contiguous float32 array, bit for bit (NaN and -0.0 stay)."""
    f, zero, one = p.reshape(-1), np.float32(0.0), np.float32(1.0)
    for i in range(f.size):
        v = f[i]
        f[i] = zero if v < zero else (one if v > one else v)


@njit(cache=True, nogil=True)
def area_quarter(p: np.ndarray, out: np.ndarray) -> None:
    """``out = cv2.resize(p, (w // 4, h // 4), interpolation=cv2.INTER_AREA)`` of a float32 (h, w)
    plane with ``h`` and ``w`` divisible by 4, bit for bit: OpenCV's fast area path sums each
    4x4 block in float32 a row of four at a time, ``0 + ((a + b) + c) + d`` and so on down
    the block, then multiplies by ``1 / 16``."""
    sh, sw = out.shape
    zero, scale = np.float32(0.0), np.float32(1.0 / 16)
    for i in range(sh):
        r0, r1, r2, r3 = p[4 * i], p[4 * i + 1], p[4 * i + 2], p[4 * i + 3]
        for j in range(sw):
            m = 4 * j
            s = zero + (((r0[m] + r0[m + 1]) + r0[m + 2]) + r0[m + 3])
            s += ((r1[m] + r1[m + 1]) + r1[m + 2]) + r1[m + 3]
            s += ((r2[m] + r2[m + 1]) + r2[m + 2]) + r2[m + 3]
            s += ((r3[m] + r3[m + 1]) + r3[m + 2]) + r3[m + 3]
            out[i, j] = s * scale


@njit(cache=True, nogil=True)
def isotonic_increasing(y: np.ndarray) -> np.ndarray:
    """The non-decreasing sequence closest to float64 ``y`` in least squares.

    The pool-adjacent-violators algorithm in the O(n) form of Busing (2022, J. Stat.
    Softw. 102(1), Algorithm 1) with unit weights: a value that is not above the last
    block's level pools with it, then absorbs the values after it that are not above
    the pooled level, then merges with earlier blocks that are not below it. A block's
    level is its weighted sum over its weight, the sum rebuilt as ``weight * level`` on
    every merge, in the order ``scipy.optimize.isotonic_regression`` computes it, so
    the two agree to the last bit (tests hold it to it).
    """
    n = y.size
    level = np.empty(n, np.float64)  # per block
    weight = np.empty(n, np.float64)
    start = np.empty(n + 1, np.int64)
    out = np.empty(n, np.float64)
    if n == 0:
        return out
    level[0], weight[0], start[0], start[1] = y[0], 1.0, 0, 1
    last, i = 0, 1
    while i < n:
        value, mass = y[i], 1.0
        last += 1
        if level[last - 1] >= value:
            last -= 1
            total = weight[last] * level[last] + mass * value
            mass += weight[last]
            value = total / mass
            while i < n - 1 and value >= y[i + 1]:
                i += 1
                total += 1.0 * y[i]
                mass += 1.0
                value = total / mass
            while last > 0 and level[last - 1] >= value:
                last -= 1
                total += weight[last] * level[last]
                mass += weight[last]
                value = total / mass
        level[last], weight[last], start[last + 1] = value, mass, i + 1
        i += 1
    for b in range(last + 1):
        out[start[b] : start[b + 1]] = level[b]
    return out
