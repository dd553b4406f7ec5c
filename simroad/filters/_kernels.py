"""Compiled per-pixel loops of the filters that no OpenCV call does (numba, ``cache=True``).

The first call of a fresh install compiles each loop once and writes the cache next to
this module. Every loop reproduces, operation by operation in float32, what the
numpy/OpenCV code it replaces computes, so the filters' outputs are bit-identical;
:mod:`tests.filters.test_kernels` holds them to their references.

Two facts the filters build on, both checked for every float32 in [0, 1]:

* ``cv2.pow`` is a function of each value alone (whatever the array around it), so an
  elementwise chain of ``cv2.pow`` and float32 arithmetic may be tabulated: a frame of
  8-bit levels ``k / 255`` (as :func:`~simroad.filters._common.to_planes` makes them)
  takes at most 256 values per channel, and a row of it under one gain at most 256.
* ``cv2.pow(x, 2.2)`` and ``cv2.pow(x, 1 / 2.2)`` never decrease on [1e-4, 1] (below,
  five neighbouring pairs of values step down by an ulp), so there an order statistic
  of the powers is the power of the order statistic.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

__all__ = [
    "LEVELS",
    "MONOTONE_FROM",
    "MONOTONE_POWERS",
    "apply_row_tables",
    "area4_floor",
    "level_codes",
    "median",
]

#: The float32 value of each 8-bit level as :func:`~simroad.filters._common.to_planes` makes it.
LEVELS = np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0)
LEVELS.setflags(write=False)
#: Powers ``cv2.pow`` was checked to be non-decreasing for on [MONOTONE_FROM, 1].
MONOTONE_POWERS = (2.2, 1.0 / 2.2)
MONOTONE_FROM = 1e-4


@njit(cache=True, nogil=True)
def level_codes(p: np.ndarray, codes: np.ndarray) -> bool:
    """Write each value's 8-bit level into ``codes`` (uint8, p's shape); whether every value
    is exactly its level's float32 in :data:`LEVELS` (if not, ``codes`` is meaningless)."""
    h, w = p.shape
    step = np.float32(1.0 / 255.0)
    for i in range(h):
        row = p[i]
        out = codes[i]
        exact = True
        for j in range(w):  # branch-free: the nearest level, and whether the value is exactly that level
            v = row[j]
            x = v * np.float32(255.0) + np.float32(0.5)
            c = np.int32(x) if (x >= np.float32(0.0)) & (x < np.float32(256.0)) else np.int32(0)  # NaN: 0
            exact &= np.float32(c) * step == v
            out[j] = c
        if not exact:
            return False
    return True


@njit(cache=True, nogil=True)
def apply_row_tables(codes: np.ndarray, tables: np.ndarray, out: np.ndarray) -> None:
    """``out[r, j] = tables[r, codes[r, j]]``: each row's 8-bit codes through that row's table (rows, 256)."""
    h, w = codes.shape
    for i in range(h):
        for j in range(w):
            out[i, j] = tables[i, codes[i, j]]


@njit(cache=True, nogil=True)
def _select(buf: np.ndarray, k: int) -> Any:
    """The ``k``-th smallest value of ``buf`` (reordered in place), quickselect."""
    lo, hi = 0, buf.size - 1
    while lo < hi:
        pivot = buf[(lo + hi) // 2]
        x, y = lo, hi
        while x <= y:
            while buf[x] < pivot:
                x += 1
            while buf[y] > pivot:
                y -= 1
            if x <= y:
                buf[x], buf[y] = buf[y], buf[x]
                x += 1
                y -= 1
        if k <= y:
            hi = y
        elif k >= x:
            lo = x
        else:
            break
    return buf[k]


@njit(cache=True, nogil=True)
def median(a: np.ndarray) -> Any:
    """``np.median`` of a non-empty float32 array without NaN, bit for bit: the middle value,
    or the float32 mean ``(lo + hi) / 2`` of the two middle ones."""
    buf = a.copy().reshape(-1)
    n = buf.size
    hi = _select(buf, n // 2)
    if n % 2:
        return hi
    lo = buf[: n // 2].max()  # after the selection, everything left of n // 2 is <= hi
    return (lo + hi) / np.float32(2.0)


@njit(cache=True, nogil=True)
def _kth_smallest(row: np.ndarray, k: int, best: np.ndarray) -> Any:
    """The ``k``-th smallest value of ``row`` (0-based, as ``np.partition``): its ``k + 1``
    smallest values kept sorted in ``best`` while it is read (``k`` is small)."""
    n = 0
    for j in range(row.size):
        v = row[j]
        if n <= k:
            n += 1
        elif v >= best[k]:
            continue
        m = n - 1
        while m > 0 and best[m - 1] > v:
            best[m] = best[m - 1]
            m -= 1
        best[m] = v
    return best[k]


@njit(cache=True, nogil=True)
def area4_floor(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, k: int, out: np.ndarray, low: float) -> bool:
    """Each row's ``k``-th smallest value of the darkest channel after a fourfold horizontal
    area reduction; returns whether any reduced value lies in (0, ``low``).

    The reduction is ``cv2.resize(p, (w // 4, h), interpolation=cv2.INTER_AREA)`` for a
    width divisible by 4, bit for bit: the float32 sum ``((0 + a) + b) + c) + d`` of each
    four neighbours, times 0.25.
    """
    h, w = p0.shape
    sw = w // 4
    row = np.empty(sw, np.float32)
    best = np.empty(k + 1, np.float32)
    zero, quarter = np.float32(0.0), np.float32(0.25)
    small = False
    for i in range(h):
        a, b, c = p0[i], p1[i], p2[i]
        for j in range(sw):
            m = 4 * j
            v0 = ((((zero + a[m]) + a[m + 1]) + a[m + 2]) + a[m + 3]) * quarter
            v1 = ((((zero + b[m]) + b[m + 1]) + b[m + 2]) + b[m + 3]) * quarter
            v2 = ((((zero + c[m]) + c[m + 1]) + c[m + 2]) + c[m + 3]) * quarter
            v = v0 if v0 < v1 else v1
            row[j] = v if v < v2 else v2
        for j in range(sw):
            small |= (row[j] > 0.0) & (row[j] < low)
        out[i] = _kth_smallest(row, k, best)
    return small
