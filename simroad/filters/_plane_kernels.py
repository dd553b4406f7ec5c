"""Compiled loops over whole float32 planes that the filter pipeline runs on every frame, numba ``cache=True``.

Each is bit for bit the numpy or OpenCV call it replaces (:mod:`tests.filters.test_kernels`
holds them to it), two to three times faster at 1280x720: the clip after a filter
(``np.clip``) and the fourfold reduction of the weather gates' preview (``cv2.resize``,
``INTER_AREA``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["area_quarter", "clip_unit"]


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
