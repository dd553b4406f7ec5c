"""The lit reference of the shadow relighting: OpenCV's box filter of the lit pixels, compiled.

:func:`lit_diff` gives each pixel of :mod:`simroad.filters.relight`'s half-resolution
ground its log colour minus the mean of the lit pixels around it (a box, a 3x larger
box where the first holds too few, else the frame's mean; :func:`minus_at` fills the
last case). The boxes reproduce ``cv2.blur`` (``BORDER_REFLECT_101``) bit for bit:
OpenCV's row sums (three or five terms left to right, else running) and running column
sums in float64, each sum times ``1 / k**2`` rounded to the dtype;
:mod:`tests.filters.test_kernels` holds them to ``cv2.blur``. Numba ``cache=True``; the
dividing loops compile with numba's numpy error model (a box's weight is at least 1e-6).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

__all__ = ["lit_diff", "minus_at"]


@njit(cache=True, nogil=True)
def _reflect101(p: int, n: int) -> int:
    """OpenCV's ``borderInterpolate(p, n, BORDER_REFLECT_101)``."""
    if n == 1:
        return 0
    while p < 0 or p >= n:
        p = -p if p < 0 else 2 * n - 2 - p
    return p


@njit(cache=True, nogil=True)
def _box_row(ext: np.ndarray, k: int, w: int, row: np.ndarray) -> None:
    """The row sums of OpenCV's box filter (``RowSum``, float64) over a bordered row ``ext``
    (4, w + k - 1) into the first ``w`` columns of ``row`` (4, at least w): three or five terms
    summed left to right, else a running sum (the four channels' chains interleaved, the first
    sums too)."""
    if k == 3 or k == 5:
        for c in range(4):
            for i in range(w):
                s = ext[c, i] + ext[c, i + 1]
                for m in range(2, k):
                    s += ext[c, i + m]
                row[c, i] = s
        return
    s0 = s1 = s2 = s3 = 0.0
    for m in range(k):
        s0 += ext[0, m]
        s1 += ext[1, m]
        s2 += ext[2, m]
        s3 += ext[3, m]
    row[0, 0], row[1, 0], row[2, 0], row[3, 0] = s0, s1, s2, s3
    for i in range(w - 1):
        s0 += ext[0, i + k] - ext[0, i]
        s1 += ext[1, i + k] - ext[1, i]
        s2 += ext[2, i + k] - ext[2, i]
        s3 += ext[3, i + k] - ext[3, i]
        row[0, i + 1], row[1, i + 1], row[2, i + 1], row[3, i + 1] = s0, s1, s2, s3


@njit(cache=True, nogil=True)
def _row_sums(logs: np.ndarray, lit: np.ndarray, sizes: tuple, upto: int, sums: np.ndarray) -> None:
    """OpenCV's row sums (float64) of the four-channel image ``[lit, logs * lit]`` (the product
    in ``lit``'s dtype) for boxes of sides ``sizes`` (one or more), at the columns below ``upto``,
    into ``sums`` (len(sizes), h, 4, w) (a row's running sum stops there: the sums up to it are
    those of the whole row). Each row is bordered once, for the largest box; a smaller
    one's bordered row lies within it."""
    h, w = lit.shape
    big = 0
    for k in sizes:
        big = max(big, k)
    n = upto + big - 1
    xs = np.empty(n, np.int64)
    for x in range(n):
        xs[x] = _reflect101(x - big // 2, w)
    ext = np.empty((4, n), np.float64)
    for y in range(h):
        for x in range(n):
            xx = xs[x]
            weight = lit[y, xx]
            ext[0, x] = weight
            ext[1, x], ext[2, x], ext[3, x] = logs[0, y, xx] * weight, logs[1, y, xx] * weight, logs[2, y, xx] * weight
        for b in range(len(sizes)):
            k = sizes[b]
            off = big // 2 - k // 2
            _box_row(ext[:, off : off + upto + k - 1], k, upto, sums[b, y])


@njit(cache=True, nogil=True)
def _column_step(sums: np.ndarray, t: int, k: int, total: np.ndarray, vals: np.ndarray) -> bool:
    """Step ``t`` of OpenCV's running column sums over the row sums (h, 4 w): the box of
    output row ``t - (k - 1)`` into ``vals`` (sum times ``1 / k**2``, rounded to its dtype);
    False while the first ``k - 1`` rows only fill the window."""
    h = sums.shape[0]
    a = k // 2
    row = sums[_reflect101(t - a, h)]
    if t < k - 1:
        for j in range(row.size):
            total[j] += row[j]
        return False
    old = sums[_reflect101(t - (k - 1) - a, h)]  # the row that leaves the window
    scale = 1.0 / (k * k)
    for j in range(row.size):
        s0 = total[j] + row[j]
        vals[j] = s0 * scale
        total[j] = s0 - old[j]
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _first_box(sums: np.ndarray, k: int, thr: Any, eps: Any, mean: np.ndarray, rest: np.ndarray) -> None:
    """The box of side ``k`` over the row sums ``sums`` (h, 4, w): ``mean[c] = box(w_c) /
    max(box(lit), eps)`` in ``mean``'s dtype for every pixel (no branch: the divisions are
    vectorised) and ``rest`` where ``box(lit)`` is at most ``thr``."""
    h, w = rest.shape
    flat = sums.reshape(h, 4 * w)
    total = np.zeros(4 * w, np.float64)
    vals = np.empty((4, w), mean.dtype)
    den = np.empty(w, mean.dtype)
    for t in range(h + k - 1):
        if not _column_step(flat, t, k, total, vals.reshape(-1)):
            continue
        y = t - (k - 1)
        for i in range(w):
            den[i] = max(vals[0, i], eps)
            rest[y, i] = not vals[0, i] > thr
        for c in range(3):
            out, num = mean[c, y], vals[1 + c]
            for i in range(w):
                out[i] = num[i] / den[i]


@njit(cache=True, nogil=True, error_model="numpy")
def _second_box(
    sums: np.ndarray, k: int, thr: Any, eps: Any, mean: np.ndarray, rest: np.ndarray, lo: int, hi: int
) -> int:  # fmt: skip
    """Where ``rest`` is set (within the columns ``lo`` to ``hi - 1``), the box of side ``k`` over
    the row sums ``sums`` (h, 4, w): its mean ``box(w_c) / max(box(lit), eps)`` into ``mean``
    where ``box(lit)`` exceeds ``thr`` (``rest`` cleared), else 0 (``rest`` becomes 2). Returns
    how many pixels neither box holds enough for. The running column sums (as
    :func:`_column_step`'s) are carried for those columns only."""
    h = rest.shape[0]
    m = hi - lo
    a = k // 2
    scale = 1.0 / (k * k)
    total = np.zeros((4, m), np.float64)
    vals = np.empty((4, m), mean.dtype)
    n = 0
    for t in range(h + k - 1):
        row = sums[_reflect101(t - a, h)]
        if t < k - 1:
            for c in range(4):
                for i in range(m):
                    total[c, i] += row[c, lo + i]
            continue
        old = sums[_reflect101(t - (k - 1) - a, h)]  # the row that leaves the window
        for c in range(4):
            for i in range(m):
                s0 = total[c, i] + row[c, lo + i]
                vals[c, i] = s0 * scale
                total[c, i] = s0 - old[c, lo + i]
        y = t - (k - 1)
        for i in range(m):
            if not rest[y, lo + i]:
                continue
            weight = vals[0, i]
            big = weight > thr
            den = max(weight, eps)
            for c in range(3):
                mean[c, y, lo + i] = vals[1 + c, i] / den if big else 0.0
            rest[y, lo + i] = 0 if big else 2
            n += not big
    return n


@njit(cache=True, nogil=True)
def lit_diff(
    logs: np.ndarray, lit: np.ndarray, sizes: tuple[int, int], thr: Any, eps: Any, diff: np.ndarray,
    rest: np.ndarray, sums: np.ndarray, eager: bool = True,
) -> int:  # fmt: skip
    """``diff = logs - mean``, ``mean`` each pixel's lit reference: the box mean of the first box
    of ``sizes`` where its weight exceeds ``thr``, else the second box's where its does, else
    0 and ``rest`` is 2 (returned: how many; the caller subtracts the frame's mean there). A
    box's mean is ``box(logs[c] * lit) / max(box(lit), eps)``, its weight ``box(lit)``.

    ``box`` is ``cv2.blur(x, (k, k))`` (``BORDER_REFLECT_101``) of the four-channel image
    ``[lit, logs * lit]`` (the product in ``lit``'s dtype, ``diff``'s), bit for bit:
    OpenCV's row sums (three or five terms left to right, else running) and running column
    sums in float64, each sum times ``1 / k**2`` rounded to the dtype (the tests hold it to
    ``cv2.blur``); the comparison, the division and the difference are in that dtype. The
    second box's sums only for the columns where the first box holds too few (from the
    first such column to the last; a row's running sum stops at the last). ``sums``
    (2, h, 4, w) float64: work space for the row sums of the two boxes. ``eager``: both
    boxes' row sums in one pass over the image (the same sums; faster where the first box
    holds too few in most columns), else the second's only for those columns.
    """
    h, w = lit.shape
    if eager:
        _row_sums(logs, lit, sizes, w, sums)
    else:
        _row_sums(logs, lit, (sizes[0],), w, sums[:1])
    _first_box(sums[0], sizes[0], thr, eps, diff, rest)
    lo, hi = w, 0  # the columns where the first box holds too few
    for y in range(h):
        for x in range(w):
            if rest[y, x]:
                lo, hi = min(lo, x), max(hi, x + 1)
    n = 0
    if lo < hi:
        if not eager:
            _row_sums(logs, lit, (sizes[1],), hi, sums[1:])
        n = _second_box(sums[1], sizes[1], thr, eps, diff, rest, lo, hi)
    src, dst = logs.reshape(-1), diff.reshape(-1)
    for i in range(dst.size):
        dst[i] = src[i] - dst[i]
    return n


@njit(cache=True, nogil=True)
def minus_at(logs: np.ndarray, frame: np.ndarray, where: np.ndarray, code: int, diff: np.ndarray) -> None:
    """``diff[c][where == code] = logs[c][where == code] - frame[c]`` (``frame`` (3,) in ``diff``'s dtype)."""
    h, w = where.shape
    for i in range(h):
        for j in range(w):
            if where[i, j] == code:
                for c in range(3):
                    diff[c, i, j] = logs[c, i, j] - frame[c]
