"""Compiled per-pixel loops of the filters that no OpenCV call does (numba, ``cache=True``);
the shadow relighting's own loops are in :mod:`simroad.filters._relight_kernels`.

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

import math
from typing import Any

import numpy as np
from numba import njit

__all__ = [
    "LEVELS",
    "MONOTONE_FROM",
    "MONOTONE_POWERS",
    "apply_row_tables",
    "apply_shared_tables",
    "area4_floor",
    "clipped_top",
    "count_below",
    "fill_rows",
    "level_codes",
    "level_rows",
    "linear_halves",
    "masked_medians",
    "median",
    "median_at_most",
    "percentile_below",
    "quantize_take",
    "response_forward",
    "response_inverse",
    "row_runs",
    "table_rows",
    "uint8_planes",
]

#: The float32 value of each 8-bit level as :func:`~simroad.filters._common.to_planes` makes it.
LEVELS = np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0)
LEVELS.setflags(write=False)
#: Powers ``cv2.pow`` was checked to be non-decreasing for on [MONOTONE_FROM, 1] (the haze
#: step's gamma: every float32 on an Intel CPU, the kernel test's million values on an AMD EPYC). ``1 / 2.2`` is not on every CPU: on
#: an AMD EPYC, OpenCV's vectorised ``pow`` falls by an ulp between neighbouring values.
MONOTONE_POWERS = (2.2,)
MONOTONE_FROM = 1e-4


@njit(cache=True, nogil=True)
def uint8_planes(image: np.ndarray, levels: np.ndarray, out: np.ndarray) -> None:
    """``out[c] = levels[image[..., c]]``: an (H, W, 3) uint8 frame as three float32 planes (3, H, W)."""
    h, w, _ = image.shape
    for i in range(h):
        for j in range(w):
            out[0, i, j] = levels[image[i, j, 0]]
            out[1, i, j] = levels[image[i, j, 1]]
            out[2, i, j] = levels[image[i, j, 2]]


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
def apply_shared_tables(codes: np.ndarray, tables: np.ndarray, table_of: np.ndarray, out: np.ndarray) -> None:
    """``out[r, j] = tables[table_of[r], codes[r, j]]``: each row's 8-bit codes through its table (k, 256)."""
    h, w = codes.shape
    for i in range(h):
        table = tables[table_of[i]]
        for j in range(w):
            out[i, j] = table[codes[i, j]]


@njit(cache=True, nogil=True)
def _quantize_row(row: np.ndarray, top: Any, idx: np.ndarray) -> None:
    """``idx = int(clip(rint(row * top), 0, top))`` in float32 (``top`` float32, < 2**23), as
    numpy computes it; NaN: 0. ``rint`` of ``0 <= x < 2**23`` is ``(x + 2**23) - 2**23`` in
    float32 (round half to even): with the clip as selects the loop vectorises."""
    big = np.float32(8388608.0)
    for j in range(row.size):
        x = row[j] * top
        x = x if x > np.float32(0.0) else np.float32(0.0)
        x = x if x < top else top
        idx[j] = np.uint32((x + big) - big)


@njit(cache=True, nogil=True)
def quantize_take(p: np.ndarray, table: np.ndarray, out: np.ndarray) -> None:
    """``out = table[clip(rint(p * (n - 1)), 0, n - 1)]`` for a table of ``n`` levels."""
    top = np.float32(table.size - 1)
    h, w = p.shape
    idx = np.empty(w, np.uint32)  # unsigned: the gather needs no wrap-around test
    for i in range(h):
        _quantize_row(p[i], top, idx)
        dst = out[i]
        for j in range(w):
            dst[j] = table[idx[j]]


@njit(cache=True, nogil=True)
def linear_halves(p: np.ndarray, table: np.ndarray, out: np.ndarray) -> None:
    """``cv2.resize(quantize_take(p), (w // 2, h // 2), interpolation=cv2.INTER_AREA)`` of a
    plane of even height and width, without the full-size linear plane.

    OpenCV's twofold area reduction of float32 sums each 2x2 block as
    ``((a + b) + (c + d)) * 0.25`` in its 4-lane vector loop and as ``(((a + b) + c) + d) * 0.25``
    in the scalar loop of the last ``(w // 2) % 4`` outputs of a row (``a b`` above ``c d``);
    the tests hold this to ``cv2.resize``.
    """
    top = np.float32(table.size - 1)
    h2, w2 = out.shape
    w = 2 * w2
    vec = w2 - w2 % 4
    quarter = np.float32(0.25)
    i0, i1 = np.empty(w, np.uint32), np.empty(w, np.uint32)
    for i in range(h2):
        _quantize_row(p[2 * i], top, i0)
        _quantize_row(p[2 * i + 1], top, i1)
        dst = out[i]
        for j in range(w2):
            a, b = table[i0[2 * j]], table[i0[2 * j + 1]]
            c, d = table[i1[2 * j]], table[i1[2 * j + 1]]
            dst[j] = ((a + b) + (c + d)) * quarter if j < vec else (((a + b) + c) + d) * quarter


@njit(cache=True, nogil=True)
def masked_medians(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``np.median(x[:, mask], axis=1)`` of a (C, H, W) array and a bool (H, W) mask with
    at least one pixel, bit for bit: each channel's values gathered, then :func:`median`."""
    c, h, w = x.shape
    n = 0
    for i in range(h):
        for j in range(w):
            n += mask[i, j]
    buf = np.empty(n, x.dtype)
    out = np.empty(c, x.dtype)
    for k in range(c):
        m = 0
        for i in range(h):
            for j in range(w):
                if mask[i, j]:
                    buf[m] = x[k, i, j]
                    m += 1
        out[k] = median(buf)
    return out


@njit(cache=True, nogil=True)
def response_inverse(z: np.ndarray, one_k: Any, k: Any) -> None:
    """``z = z / (one_k - k * z)`` in place, float32 (the camera response's shoulder undone)."""
    flat = z.reshape(-1)
    for i in range(flat.size):
        v = flat[i]
        flat[i] = v / (one_k - k * v)


@njit(cache=True, nogil=True)
def response_forward(y: np.ndarray, gain: Any, one_k: Any, k: Any, out: np.ndarray) -> int:
    """``out = one_k * c / (1 + k * c)`` with ``c = clip(y * gain, 0, 1)``, float32 (the shoulder
    applied); returns how many outputs are zero."""
    src, dst = y.reshape(-1), out.reshape(-1)
    zero, one = np.float32(0.0), np.float32(1.0)
    zeros = 0
    for i in range(src.size):
        v = src[i] * gain
        v = zero if v < zero else (one if v > one else v)  # np.clip (NaN stays NaN)
        z = one_k * v / (one + k * v)
        dst[i] = z
        zeros += z == zero
    return zeros


@njit(cache=True, nogil=True)
def level_rows(p: np.ndarray, lut: np.ndarray, out: np.ndarray, codes: np.ndarray, rows: np.ndarray) -> None:
    """For each row of ``p`` whose values are all exactly 8-bit levels (``rows[i]`` True): the
    levels into ``codes`` and ``lut[level]`` into ``out``; any other row is left as it is."""
    h, w = p.shape
    step = np.float32(1.0 / 255.0)
    for i in range(h):
        exact = True
        for j in range(w):
            v = p[i, j]
            x = v * np.float32(255.0) + np.float32(0.5)
            c = np.int32(x) if (x >= np.float32(0.0)) & (x < np.float32(256.0)) else np.int32(0)
            exact &= np.float32(c) * step == v
            codes[i, j] = c
        rows[i] = exact
        if exact:
            for j in range(w):
                out[i, j] = lut[codes[i, j]]


@njit(cache=True, nogil=True)
def table_rows(codes: np.ndarray, rows: np.ndarray, table: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = table[codes[i]]`` for the rows with ``rows[i]`` True (the others are left as they are)."""
    h, w = codes.shape
    for i in range(h):
        if rows[i]:
            for j in range(w):
                out[i, j] = table[codes[i, j]]


def row_runs(rows: np.ndarray) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of the runs of False in a bool (h,) array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[True], rows, [True]]).astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


@njit(cache=True, nogil=True)
def count_below(x: np.ndarray, t: float) -> int:
    """How many values of ``x`` are below ``t`` (compared as float64, like ``float(v) < t``)."""
    n = 0
    for v in x.reshape(-1):
        if np.float64(v) < t:
            n += 1
    return n


@njit(cache=True, nogil=True)
def fill_rows(planes: np.ndarray, holes: np.ndarray) -> None:
    """Replace ``holes`` in each of the (C, H, W) planes, row by row, by the straight line
    between their nearest non-hole neighbours (in place): ``a + (b - a) * frac`` in float32,
    ``frac = float32((col - left) / max(right - left, 1))``; a hole at an end of its row takes
    its one side; a row without any non-hole takes its first value."""
    nc, h, w = planes.shape
    left = np.empty(w, np.int64)
    right = np.empty(w, np.int64)
    for i in range(h):
        last = -1
        for j in range(w):
            if not holes[i, j]:
                last = j
            left[j] = last
        nxt = w
        for j in range(w - 1, -1, -1):
            if not holes[i, j]:
                nxt = j
            right[j] = nxt
        for j in range(w):
            if not holes[i, j]:
                continue
            li = left[j] if left[j] >= 0 else (right[j] if right[j] < w else 0)
            ri = right[j] if right[j] < w else li
            frac = np.float32((j - li) / max(ri - li, 1))
            for c in range(nc):
                a, b = planes[c, i, li], planes[c, i, ri]
                planes[c, i, j] = a + (b - a) * frac


@njit(cache=True, nogil=True)
def clipped_top(
    p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, lobe: np.ndarray, depth: float, spread: Any, top: np.ndarray
) -> int:  # fmt: skip
    """The brightest pixels of a non-empty ``lobe``: ``top = lobe & (hi >= f32(max(hi[lobe]) - depth))``
    with ``hi`` the largest channel (float32 compare, as numpy casts the Python threshold);
    returns how many of them are grey, ``hi - lo <= spread`` (float32)."""
    h, w = lobe.shape
    brightest = np.float32(-np.inf)
    for i in range(h):
        for j in range(w):
            if lobe[i, j]:
                brightest = max(brightest, max(max(p0[i, j], p1[i, j]), p2[i, j]))
    level = np.float32(np.float64(brightest) - depth)
    grey = 0
    for i in range(h):
        for j in range(w):
            a, b, c = p0[i, j], p1[i, j], p2[i, j]
            hi = max(max(a, b), c)
            t = lobe[i, j] & (hi >= level)
            top[i, j] = t
            if t and hi - min(min(a, b), c) <= spread:
                grey += 1
    return grey


@njit(cache=True, nogil=True)
def median_at_most(values: np.ndarray, t: float) -> bool:
    """Whether ``float(np.median(values)) <= t`` for a non-empty float32 array without NaN,
    without sorting: from how many values are ``<= t`` and, when exactly half are, the
    two middle values (the largest ``<= t`` and the smallest above it)."""
    n = values.size
    count = 0
    below = -np.inf
    above = np.inf
    for v in values.reshape(-1):
        if v <= t:
            count += 1
            below = max(below, v)
        else:
            above = min(above, v)
    k = n // 2
    if n % 2 or count != k:
        return count > k
    mid = (np.float32(below) + np.float32(above)) / np.float32(2.0)  # np.median's float32 mean of the middle two
    return bool(mid <= t)


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


def percentile_below(x: np.ndarray, q: float, t: float) -> bool:
    """Whether ``float(np.percentile(x, q)) < t`` (x float32 without NaN), mostly by counting.

    The percentile lies between the order statistics around ``q / 100 * (n - 1)``: when
    enough values are below ``t`` (or too few), both are (or neither is); only when the
    count falls between them is the percentile itself computed.
    """
    n = x.size
    v = q / 100.0 * (n - 1)
    below = count_below(x, float(t))
    if below >= math.floor(v + 1e-6) + 2:  # the order statistic after the percentile's is below t
        return True
    if below <= math.floor(v - 1e-6):  # the one before it is not
        return False
    return float(np.percentile(x, q)) < t
