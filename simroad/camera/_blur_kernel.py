"""The sensor's radial motion blur, compiled: per-pixel box along the flow from the focus of expansion.

Pixel ``p`` integrates the radiance at ``p + t (p - e) s(p)``, ``t`` in [0, 1] (see
:func:`simroad.camera._sensor_ops.radial_motion_blur`). The box is built by
doubling: after level ``j`` a pixel holds the mean of ``2**(j+1)`` taps, level ``j``
averaging the pixel with the previous level's value ``2**j`` tap spacings farther
along its flow (bilinear, border replicated). Each pixel takes only the levels its
own blur length needs (``n = ceil(log2(L / max_step + 1))`` for ``L = s |p - e|``,
none below half a pixel), with its own tap spacing ``L / (2**n - 1)``, so the cost
follows the blur actually in the frame rather than its longest streak.

A level runs in place, one row at a time: the flow points away from the horizon row,
so a row below it reads only rows at or below itself and a row above it only rows at
or above itself; visiting rows outwards from the horizon and writing each row after
it is computed, every read sees the previous level. ``parallel=False``: the
simulation's workers already use every core.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["decode", "radial_blur", "radial_blur_depth"]

_FM = {"reassoc", "contract", "nsz", "arcp"}
_MAX_LEVELS = 8


@njit(cache=True, nogil=True)
def decode(frame, table, out):
    """``out = table[frame]``: an 8-bit (H, W, 3) frame to float32 through a 256-entry table."""
    src, dst = frame.reshape(-1), out.reshape(-1)
    for i in range(src.size):
        dst[i] = table[src[i]]


@njit(cache=True, nogil=True, fastmath=_FM, inline="always")
def _plan_pixel(s, du, dv, max_step):
    """Doublings ``n`` and the displacement of one tap spacing for expansion ``s`` at
    offset (``du``, ``dv``) from the focus of expansion."""
    length = s * math.sqrt(du * du + dv * dv)
    # n = ceil(log2(L / max_step + 1)): the fewest doublings whose 2**n - 1 spacings
    # of at most max_step cover L; none below half a pixel.
    if not length >= 0.5:
        return 0, np.float32(0.0), np.float32(0.0)
    n = 1
    while n < _MAX_LEVELS and np.float32((1 << n) - 1) * max_step < length:
        n += 1
    k = s / np.float32((1 << n) - 1)
    return n, k * du, k * dv


@njit(cache=True, nogil=True, fastmath=_FM)
def _plan(scale, cx, foe_row, max_step, fx, fy, levels, row_levels):
    """Per pixel: the displacement of one tap spacing (``fx``, ``fy``) and the number of
    levels; per row, the most levels of any of its pixels. Returns the frame's most."""
    h, w = scale.shape
    most = 0
    for y in range(h):
        dv = np.float32(y - foe_row)
        row_most = 0
        for x in range(w):
            n, fx[y, x], fy[y, x] = _plan_pixel(scale[y, x], np.float32(x - cx), dv, max_step)
            levels[y, x] = n
            row_most = max(row_most, n)
        row_levels[y] = row_most
        most = max(most, row_most)
    return most


@njit(cache=True, nogil=True, fastmath=_FM)
def _plan_depth(depth, mask, inv_cos, travel, cx, foe_row, max_step, fx, fy, levels, row_levels):
    """:func:`_plan` with ``s = travel / max(X - travel, travel)`` from the depth map
    (``X = depth / inv_cos``, :func:`simroad.camera._sensor_ops.motion_blur_scale`),
    for the pixels of ``mask`` only."""
    h, w = depth.shape
    most = 0
    for y in range(h):
        dv = np.float32(y - foe_row)
        row_most = 0
        for x in range(w):
            n = 0
            if mask[y, x]:
                forward = depth[y, x] / inv_cos[x]
                s = travel / max(forward - travel, travel)
                n, fx[y, x], fy[y, x] = _plan_pixel(s, np.float32(x - cx), dv, max_step)
            levels[y, x] = n
            row_most = max(row_most, n)
        row_levels[y] = row_most
        most = max(most, row_most)
    return most


@njit(cache=True, nogil=True, fastmath=_FM)
def _level_row(img, y, j, fx, fy, levels, tmp):
    """Level ``j`` of row ``y`` into ``tmp`` (then copied into the image)."""
    h, w = img.shape[0], img.shape[1]
    step = np.float32(1 << j)
    wm, hm = np.float32(w - 1), np.float32(h - 1)
    for x in range(w):
        if levels[y, x] <= j:
            continue
        qx = min(max(np.float32(x) + step * fx[y, x], np.float32(0.0)), wm)
        qy = min(max(np.float32(y) + step * fy[y, x], np.float32(0.0)), hm)
        x0, y0 = int(qx), int(qy)
        ax, ay = qx - np.float32(x0), qy - np.float32(y0)
        x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
        for c in range(3):
            top = img[y0, x0, c] + ax * (img[y0, x1, c] - img[y0, x0, c])
            bot = img[y1, x0, c] + ax * (img[y1, x1, c] - img[y1, x0, c])
            tmp[x, c] = np.float32(0.5) * (img[y, x, c] + top + ay * (bot - top))
    for x in range(w):  # only the pixels of this level change
        if levels[y, x] > j:
            for c in range(3):
                img[y, x, c] = tmp[x, c]


@njit(cache=True, nogil=True, fastmath=_FM)
def _run_levels(img, fx, fy, levels, row_levels, most, foe_row):
    h, w = levels.shape
    tmp = np.empty((w, 3), np.float32)
    first_below = min(max(int(math.floor(foe_row)) + 1, 0), h)
    for j in range(most):
        for y in range(first_below, h):  # below the horizon: outwards = downwards
            if row_levels[y] > j:
                _level_row(img, y, j, fx, fy, levels, tmp)
        for y in range(first_below - 1, -1, -1):  # above it: upwards
            if row_levels[y] > j:
                _level_row(img, y, j, fx, fy, levels, tmp)


@njit(cache=True, nogil=True, fastmath=_FM)
def radial_blur(img, scale, cx, foe_row, max_step):
    """Blur ``img`` (float32 (H, W, 3), C-contiguous) in place along the radial flow.

    ``scale`` is the relative expansion ``s`` per pixel (float32 (H, W)), ``(cx,
    foe_row)`` the focus of expansion in pixels, ``max_step`` the largest tap spacing in
    pixels. Returns the number of levels of the longest blur (0: nothing moved).
    """
    h, w = scale.shape
    fx = np.empty((h, w), np.float32)  # read only where levels > 0
    fy = np.empty((h, w), np.float32)
    levels = np.empty((h, w), np.uint8)
    row_levels = np.empty(h, np.int64)
    most = _plan(scale, np.float32(cx), np.float32(foe_row), np.float32(max_step), fx, fy, levels, row_levels)
    _run_levels(img, fx, fy, levels, row_levels, most, foe_row)
    return most


@njit(cache=True, nogil=True, fastmath=_FM)
def radial_blur_depth(img, depth, mask, inv_cos, travel, cx, foe_row, max_step):
    """:func:`radial_blur` of the pixels of ``mask`` (bool (H, W)), the expansion from
    the depth map (float32 (H, W), ``inf`` for the sky), the columns' ``1 / cos`` of
    their bearing (float32 (W,)) and the travel during the exposure (m)."""
    h, w = depth.shape
    fx = np.empty((h, w), np.float32)  # read only where levels > 0
    fy = np.empty((h, w), np.float32)
    levels = np.empty((h, w), np.uint8)
    row_levels = np.empty(h, np.int64)
    most = _plan_depth(
        depth,
        mask,
        inv_cos,
        np.float32(travel),
        np.float32(cx),
        np.float32(foe_row),
        np.float32(max_step),
        fx,
        fy,
        levels,
        row_levels,
    )
    _run_levels(img, fx, fy, levels, row_levels, most, foe_row)
    return most
