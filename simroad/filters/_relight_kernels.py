"""Compiled per-pixel loops of the shadow relighting (:mod:`simroad.filters.relight`), numba ``cache=True``.

As in :mod:`simroad.filters._kernels` (the loops the other filters share): each loop
reproduces, operation by operation, what the numpy/OpenCV code it replaces computes, so
the filter's output is bit-identical; :mod:`tests.filters.test_kernels` holds them to
their references (the lit reference's box filters, OpenCV's running sums, are in
:mod:`simroad.filters._lit_boxes`). The projections reproduce a library's order rather
than a documented one: the order in which OpenBLAS's gemv sums three products
(``np.tensordot``; the test compares with it within 1e-6, so another BLAS would fail
only that). A maximum (:func:`first_lit`) is exact in
any order. The loops that divide compile with numba's numpy error model (no
ZeroDivisionError test, so LLVM vectorises the divisions): a box's weight is at least
1e-6 and ``d @ d`` positive; ``(d - mean d) @ itself`` is 0 only for a grey ``d`` (every
channel capped at -1e-3), where the chroma is now NaN (no shadow, the frame unchanged)
and the numpy code's compiled division raised ZeroDivisionError.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from simroad.filters._kernels import _quantize_row, _select, median

__all__ = [
    "alpha_chroma",
    "clip_inside",
    "edge_pairs",
    "first_lit",
    "first_lit_work",
    "lit_outside",
    "next_direction",
    "project",
    "put_at",
    "relit_linear",
    "shadow_update",
    "sky_ratios",
    "strong_median",
]


@njit(cache=True, nogil=True)
def sky_ratios(
    p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, table: np.ndarray, sat: Any, red: Any, dark: Any, out: np.ndarray
) -> int:  # fmt: skip
    """The linear ``B / R`` of the pixels whose channels (each through ``table``, as
    :func:`quantize_take`) stay below ``sat``, with red above ``red`` and blue above
    ``dark`` (float32 thresholds), in row-major order into ``out``; returns their number."""
    top = np.float32(table.size - 1)
    h, w = p0.shape
    i0, i1, i2 = np.empty(w, np.uint32), np.empty(w, np.uint32), np.empty(w, np.uint32)
    n = 0
    for i in range(h):
        _quantize_row(p0[i], top, i0)
        _quantize_row(p1[i], top, i1)
        _quantize_row(p2[i], top, i2)
        for j in range(w):
            r, g, b = table[i0[j]], table[i1[j]], table[i2[j]]
            if (max(max(r, g), b) < sat) & (r > red) & (b > dark):
                out[n] = b / r
                n += 1
    return n


@njit(cache=True, nogil=True)
def edge_pairs(logs: np.ndarray, valid: np.ndarray, shift: int, drop: Any, bluer: Any) -> np.ndarray:
    """Log differences (dark - lit) of the shadow-like pixel pairs ``shift`` apart, as
    an (N, 3) array in the order the numpy reference lists them: horizontal pairs then
    vertical ones, each as ``b - a`` then ``a - b``, pixels in row-major order. A pair is
    shadow-like when both pixels are valid and the difference darkens every channel, red
    below ``-drop`` and most, blue least, ``b - r > bluer * -r`` (float32 thresholds).
    The red difference is tested first: most pairs stop there."""
    h, w = valid.shape
    out = np.empty((4 * h * w, 3), logs.dtype)  # only the pages written are ever touched
    n = 0
    zero = np.float32(0.0)
    for dy, dx in ((0, shift), (shift, 0)):
        for sign in (np.float32(1.0), np.float32(-1.0)):
            for i in range(h - dy):
                for j in range(w - dx):
                    r = (logs[0, i + dy, j + dx] - logs[0, i, j]) * sign
                    if not (r < -drop) or not (valid[i, j] and valid[i + dy, j + dx]):
                        continue
                    g = (logs[1, i + dy, j + dx] - logs[1, i, j]) * sign
                    b = (logs[2, i + dy, j + dx] - logs[2, i, j]) * sign
                    if (r < g) and (g < b) and (b < zero) and (b - r > bluer * -r):
                        out[n, 0], out[n, 1], out[n, 2] = r, g, b
                        n += 1
    return out[:n]


@njit(cache=True, nogil=True)
def _percentile(x: np.ndarray, q: float) -> Any:
    """``np.percentile(x, q)`` (linear) of a non-empty float32 array without NaN, bit for bit:
    the order statistics around ``(n - 1) * (q / 100)`` (``x`` is reordered) and numpy's
    ``_lerp`` of them in float32 (``b - (b - a) * (1 - t)`` from ``t = 0.5`` on)."""
    n = x.size
    v = (n - 1) * (q / 100.0)
    lo = n - 1 if v >= n - 1 else int(math.floor(v))
    hi = min(lo + 1, n - 1)
    b = _select(x, hi)
    a = x[:hi].max() if lo < hi else b  # after the selection, everything left of hi is <= b
    t = v - lo
    step = b - a
    if t >= 0.5:
        return b - step * np.float32(1.0 - t)
    return a + step * np.float32(t)


@njit(cache=True, nogil=True)
def strong_median(pairs: np.ndarray, q: float) -> np.ndarray:
    """``np.median(pairs[-pairs[:, 0] >= np.percentile(-pairs[:, 0], q)], axis=0)`` of a non-empty
    float32 (N, 3) array without NaN, bit for bit (:func:`_percentile`, then
    :func:`~simroad.filters._kernels.median` of each column of the rows kept)."""
    n = pairs.shape[0]
    drop = np.empty(n, pairs.dtype)
    for i in range(n):
        drop[i] = -pairs[i, 0]
    thr = _percentile(drop.copy(), q)
    keep = np.empty((3, n), pairs.dtype)
    m = 0
    for i in range(n):
        if drop[i] >= thr:
            keep[0, m], keep[1, m], keep[2, m] = pairs[i, 0], pairs[i, 1], pairs[i, 2]
            m += 1
    out = np.empty(3, pairs.dtype)
    for c in range(3):
        out[c] = median(keep[c, :m])
    return out


@njit(cache=True, nogil=True)
def _max_down(x: np.ndarray, k: int, first: np.ndarray, last: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = max(x[i - k // 2 : i - k // 2 + k])`` down each column of ``x`` (n, m), the window
    cut at the edges (as ``cv2.dilate``'s border): van Herk / Gil-Werman, the prefix and
    suffix maxima within blocks of ``k`` of the columns padded with -inf, the columns side
    by side (vectorised); ``first`` and ``last`` ((n + k - 1) * m each) hold them."""
    n, m = x.shape
    a = k // 2
    size = n + k - 1
    pad = np.full(m, -np.inf, x.dtype)
    first = first[: size * m].reshape(size, m)  # max from the start of the block
    last = last[: size * m].reshape(size, m)  # max to the end of the block
    for j in range(size):
        row = x[j - a] if 0 <= j - a < n else pad
        if j % k == 0:
            first[j] = row
        else:
            for c in range(m):
                first[j, c] = max(first[j - 1, c], row[c])
    for j in range(size - 1, -1, -1):
        row = x[j - a] if 0 <= j - a < n else pad
        if j % k == k - 1 or j == size - 1:
            last[j] = row
        else:
            for c in range(m):
                last[j, c] = max(last[j + 1, c], row[c])
    for i in range(n):
        for c in range(m):
            out[i, c] = max(last[i, c], first[i + k - 1, c])


def first_lit_work(h: int, w: int, k: int) -> int:
    """How many float32 values :func:`first_lit`'s ``work`` must hold for an (h, w) image and side ``k``."""
    return 2 * max((h + k - 1) * w, (w + k - 1) * h) + 3 * h * w


@njit(cache=True, nogil=True)
def first_lit(bright: np.ndarray, lit_ok: np.ndarray, k: int, step: Any, out: np.ndarray, work: np.ndarray) -> None:
    """``out = lit_ok * (bright >= cv2.dilate(bright, np.ones((k, k), np.uint8)) - step)``
    (float32, ``step`` float32): the maximum over the box, exact in any order, down the
    columns then along the rows (:func:`_max_down` of the transposed). ``work``: float32
    work space of :func:`first_lit_work` values."""
    h, w = bright.shape
    span = max((h + k - 1) * w, (w + k - 1) * h)
    first, last = work[:span], work[span : 2 * span]
    rest = work[2 * span :]
    down = rest[: h * w].reshape(h, w)
    turned = rest[h * w : 2 * h * w].reshape(w, h)
    across = rest[2 * h * w : 3 * h * w].reshape(w, h)
    _max_down(bright, k, first, last, down)
    for i in range(h):
        for j in range(w):
            turned[j, i] = down[i, j]
    _max_down(turned, k, first, last, across)
    zero = np.float32(0.0)
    for i in range(h):
        for j in range(w):
            out[i, j] = lit_ok[i, j] if bright[i, j] >= across[j, i] - step else zero


@njit(cache=True, nogil=True, error_model="numpy")
def project(x: np.ndarray, d: np.ndarray, den: Any, out: np.ndarray) -> None:
    """``out = float32((d[0] * x[0] + d[1] * x[1]) + d[2] * x[2]) / den``: the coordinate of each
    pixel of ``x`` (3, H, W) along ``d`` (3,), products and sums in their common dtype, ``den``
    float32: ``np.tensordot(d, x, 1).astype(np.float32) / den`` where the BLAS sums the three
    products in this order (OpenBLAS's gemv here: the tests compare)."""
    a, b, c = x[0].reshape(-1), x[1].reshape(-1), x[2].reshape(-1)
    dst = out.reshape(-1)
    for i in range(a.size):
        dst[i] = np.float32((d[0] * a[i] + d[1] * b[i]) + d[2] * c[i]) / den


@njit(cache=True, nogil=True, error_model="numpy")
def alpha_chroma(
    diff: np.ndarray, d: np.ndarray, dd: Any, dc: np.ndarray, dcc: Any, alpha: np.ndarray, chroma: np.ndarray
) -> None:  # fmt: skip
    """Two projections (as :func:`project`) in one pass over ``diff`` (3, H, W): ``alpha`` of
    ``diff`` on ``d`` over ``dd``; ``chroma`` of ``diff - diff.mean(axis=0)`` (numpy's
    ``(x0 + x1) + x2`` over 3, in ``diff``'s dtype) on ``dc`` over ``dcc``."""
    a, b, c = diff[0].reshape(-1), diff[1].reshape(-1), diff[2].reshape(-1)
    da, ch = alpha.reshape(-1), chroma.reshape(-1)
    three = diff.dtype.type(3.0)
    for i in range(a.size):
        x, y, z = a[i], b[i], c[i]
        da[i] = np.float32((d[0] * x + d[1] * y) + d[2] * z) / dd
        m = ((x + y) + z) / three
        ch[i] = np.float32((dc[0] * (x - m) + dc[1] * (y - m)) + dc[2] * (z - m)) / dcc


@njit(cache=True, nogil=True)
def next_direction(
    diff: np.ndarray, core: np.ndarray, d: np.ndarray, fewest: int, cap: Any, new: np.ndarray
) -> tuple[int, float]:  # fmt: skip
    """The shadow step re-estimated over the cores: how many pixels of ``core`` ((h, w), any
    nonzero value set) are set and, when more than ``fewest``, ``new = np.minimum(np.median(
    diff[:, core != 0], axis=1), cap)`` (each channel by :func:`~simroad.filters._kernels.median`,
    bit for bit) and how far it moved, ``float(np.abs(new - d).max())``, else 0.0."""
    flat = core.reshape(-1)
    where = np.empty(flat.size, np.int64)
    n = 0
    for i in range(flat.size):
        if flat[i]:
            where[n] = i
            n += 1
    if n <= fewest:
        return n, 0.0
    buf = np.empty(n, diff.dtype)
    moved = 0.0
    for c in range(3):
        plane = diff[c].reshape(-1)
        for m in range(n):
            buf[m] = plane[where[m]]
        new[c] = min(median(buf), cap)
        moved = max(moved, abs(new[c] - d[c]))
    return n, moved


@njit(cache=True, nogil=True)
def clip_inside(alpha: np.ndarray, region: np.ndarray, out: np.ndarray) -> None:
    """``out = np.where(region > 0, np.clip(alpha, 0, 1), 0)`` in float32 (NaN stays NaN, as in np.clip)."""
    h, w = region.shape
    zero, one = np.float32(0.0), np.float32(1.0)
    for i in range(h):
        for j in range(w):
            v = alpha[i, j]
            v = zero if v < zero else (one if v > one else v)
            out[i, j] = v if region[i, j] > 0 else zero


@njit(cache=True, nogil=True)
def _level(v: Any, top: Any) -> int:
    """One value of :func:`~simroad.filters._kernels._quantize_row`: ``int(clip(rint(v * top), 0, top))`` in float32."""
    x = v * top
    x = x if x > np.float32(0.0) else np.float32(0.0)
    x = x if x < top else top
    return int((x + np.float32(8388608.0)) - np.float32(8388608.0))


@njit(cache=True, nogil=True, error_model="numpy")
def relit_linear(
    full: np.ndarray, thr: Any, p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, table: np.ndarray, ks: np.ndarray,
    where: np.ndarray, lin: np.ndarray, mask: np.ndarray,
) -> int:  # fmt: skip
    """The pixels whose ``full`` (h, w) exceeds ``thr`` (float32), in row-major order: their flat
    indices into ``where``, ``mask`` set, and each channel's relit linear signal ``table[q(p_c)]
    / (1 - a * (1 - ks[c]))`` into ``lin[c]`` (float32; ``q`` as :func:`~simroad.filters._kernels.quantize_take`,
    ``a`` the pixel's ``full``); returns how many."""
    h, w = full.shape
    top = np.float32(table.size - 1)
    one = np.float32(1.0)
    n = 0
    for i in range(h):
        for j in range(w):
            a = full[i, j]
            mask[i, j] = a > thr
            if not a > thr:
                continue
            where[n] = i * w + j
            lin[0, n] = table[_level(p0[i, j], top)] / (one - a * (one - ks[0]))
            lin[1, n] = table[_level(p1[i, j], top)] / (one - a * (one - ks[1]))
            lin[2, n] = table[_level(p2[i, j], top)] / (one - a * (one - ks[2]))
            n += 1
    return n


@njit(cache=True, nogil=True)
def put_at(where: np.ndarray, values: np.ndarray, p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> None:
    """``p_c.flat[where] = values[c]`` for three contiguous (h, w) planes."""
    f0, f1, f2 = p0.reshape(-1), p1.reshape(-1), p2.reshape(-1)
    for m in range(where.size):
        i = where[m]
        f0[i], f1[i], f2[i] = values[0, m], values[1, m], values[2, m]


@njit(cache=True, nogil=True)
def shadow_update(
    alpha: np.ndarray, chroma: np.ndarray, valid: np.ndarray, min_alpha: Any, min_chroma: Any, shadow: np.ndarray
) -> None:  # fmt: skip
    """``shadow = uint8((alpha > min_alpha) & (chroma > min_chroma) & valid)`` (float32 thresholds)."""
    h, w = valid.shape
    for i in range(h):
        for j in range(w):
            shadow[i, j] = (alpha[i, j] > min_alpha) & (chroma[i, j] > min_chroma) & valid[i, j]


@njit(cache=True, nogil=True)
def lit_outside(lit_ok: np.ndarray, grown: np.ndarray, out: np.ndarray) -> None:
    """``out = lit_ok * (1.0 - grown)`` in float64 (``lit_ok`` float32, ``grown`` uint8), as numpy promotes it."""
    h, w = grown.shape
    for i in range(h):
        for j in range(w):
            out[i, j] = np.float64(lit_ok[i, j]) * (1.0 - np.float64(grown[i, j]))
