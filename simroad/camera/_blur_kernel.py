"""The sensor's radial motion blur, compiled: per-pixel box along the flow from the focus of expansion.

Pixel ``p`` integrates the radiance at ``p + t (p - e) s(p)``, ``t`` in [0, 1] (see
:func:`simroad.camera._sensor_ops.radial_motion_blur`). The box is built by
doubling: after level ``j`` a pixel holds the mean of ``2**(j+1)`` taps, level ``j``
averaging the pixel with the previous level's value ``2**j`` tap spacings farther
along its flow (bilinear, border replicated). Each pixel takes only the levels its
own blur length needs (``n = ceil(log2(L / max_step + 1))`` for ``L = s |p - e|``,
none below half a pixel), with its own tap spacing ``L / (2**n - 1)``, so the cost
follows the blur actually in the frame rather than its longest streak.

The plan lists the pixels that blur, row by row (``row_ptr[y] .. row_ptr[y + 1]``
index ``xs``), each with its doublings ``ns`` and the displacement of one tap spacing
(``fxs``, ``fys``): the levels visit only them. A level runs in place, one row at a
time: the flow points away from the horizon row,
so a row below it reads only rows at or below itself and a row above it only rows at
or above itself; visiting rows outwards from the horizon and writing each row after
it is computed, every read sees the previous level. ``parallel=False``: the
simulation's workers already use every core.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "NEAR_RADII",
    "decode",
    "decode_rounded",
    "face_edges",
    "face_share",
    "radial_blur",
    "radial_blur_depth",
    "radial_blur_frame",
]

_FM = {"reassoc", "contract", "nsz", "arcp"}
_MAX_LEVELS = 8
#: Radii (pixels) of the two near-edge maps of the flat-face plan (:func:`face_edges`).
NEAR_RADII = (3, 8)


@njit(cache=True, nogil=True)
def decode(frame, table, out):
    """``out = table[frame]`` element by element (C-contiguous arrays of one shape): an
    8-bit (H, W, 3) frame to float32 through a 256-entry table, or 16-bit linear light
    back to 8-bit codes (:func:`simroad.camera._ground_blur.box_blur_texture`)."""
    src, dst = frame.reshape(-1), out.reshape(-1)
    for i in range(src.size):
        dst[i] = table[src[i]]


@njit(cache=True, nogil=True)
def _round_u16(src, dst):
    for i in range(src.size):
        dst[i] = np.uint16(min(max(np.rint(src[i]), np.float32(0.0)), np.float32(65535.0)))


@njit(cache=True, nogil=True)
def decode_rounded(values, table, out):
    """``out = table[v]`` for ``v`` each of the float32 ``values`` rounded to the nearest
    integer (ties to even) and saturated to 0..65535, as OpenCV converts a float to 16
    bits (``saturate_cast<ushort>``); C-contiguous arrays of one shape."""
    src, dst = values.reshape(-1), out.reshape(-1)
    step = 4096
    chunk = np.empty(step, np.uint16)
    for start in range(0, src.size, step):
        end = min(start + step, src.size)
        part = chunk[: end - start]
        _round_u16(src[start:end], part)  # vectorised, apart from the table's gather
        decode(part, table, dst[start:end])


@njit(cache=True, nogil=True, inline="always")
def _index(v):
    """The integer part of ``v`` (a float >= 0) as an unsigned index (no wrap-around
    test when indexing). Converted through int64, one instruction: x86 without
    AVX-512 has no conversion to uint64, and the direct one takes a compare, a
    subtraction and a select; the same integer for every index below 2**63."""
    return np.uint64(np.int64(v))


@njit(cache=True, nogil=True, fastmath=_FM, inline="always")
def _blur_length(s, du, dv):
    """Blur length ``L = s |p - e|`` (pixels) for expansion ``s`` at offset (``du``, ``dv``)
    from the focus of expansion."""
    return s * math.sqrt(du * du + dv * dv)


@njit(cache=True, nogil=True, fastmath=_FM, inline="always")
def _plan_steps(s, du, dv, length, max_step):
    """Doublings ``n`` and the displacement of one tap spacing of a blur of ``length``
    >= 0.5 pixels (:func:`_blur_length`)."""
    # n = ceil(log2(L / max_step + 1)): the fewest doublings whose 2**n - 1 spacings
    # of at most max_step cover L.
    n = 1
    while n < _MAX_LEVELS and np.float32((1 << n) - 1) * max_step < length:
        n += 1
    k = s / np.float32((1 << n) - 1)
    return n, k * du, k * dv


@njit(cache=True, nogil=True, fastmath=_FM, inline="always")
def _plan_pixel(s, du, dv, max_step):
    """Doublings ``n`` and the displacement of one tap spacing for expansion ``s`` at
    offset (``du``, ``dv``) from the focus of expansion; none below half a pixel."""
    length = _blur_length(s, du, dv)
    if not length >= 0.5:
        return 0, np.float32(0.0), np.float32(0.0)
    return _plan_steps(s, du, dv, length, max_step)


@njit(cache=True, nogil=True, fastmath=_FM)
def _empty_plan(h, w):
    cap = h * w
    return (
        np.empty(cap, np.int32),
        np.empty(cap, np.uint8),
        np.empty(cap, np.float32),
        np.empty(cap, np.float32),
        np.zeros(h + 1, np.int64),
    )


@njit(cache=True, nogil=True, fastmath=_FM)
def _plan(scale, cx, foe_row, max_step):
    """The pixels to blur from the relative expansion ``s`` per pixel; returns the plan
    ``(xs, ns, fxs, fys, row_ptr, most)`` (see the module docstring)."""
    h, w = scale.shape
    xs, ns, fxs, fys, row_ptr = _empty_plan(h, w)
    k, most = 0, 0
    for y in range(h):
        dv = np.float32(y - foe_row)
        for x in range(w):
            n, fx, fy = _plan_pixel(scale[y, x], np.float32(x - cx), dv, max_step)
            if n > 0:
                xs[k], ns[k], fxs[k], fys[k] = x, n, fx, fy
                k += 1
                most = max(most, n)
        row_ptr[y + 1] = k
    return xs, ns, fxs, fys, row_ptr, most


@njit(cache=True, nogil=True, fastmath=_FM, inline="always")
def _stays_on_face(face_id, fid, x, y, lx, ly):
    """Whether every bilinear tap of pixel (``x``, ``y``)'s flow segment (to
    ``(x + lx, y + ly)``) reads face ``fid`` only: the four texels around its end, and
    the segment's quarter points for anything standing in between. A face is convex
    on the screen, so the taps between read it too."""
    h, w = face_id.shape
    wm, hm = np.float32(w - 1), np.float32(h - 1)
    zero = np.float32(0.0)
    # The end's four texels (clamped like the taps; the integer part of a
    # non-negative float is its floor). Unsigned indices: no wrap-around test.
    x0 = _index(min(max(np.float32(x) + lx, zero), wm))
    y0 = _index(min(max(np.float32(y) + ly, zero), hm))
    x1, y1 = min(x0 + np.uint64(1), np.uint64(w - 1)), min(y0 + np.uint64(1), np.uint64(h - 1))
    if face_id[y0, x0] != fid or face_id[y1, x1] != fid or face_id[y0, x1] != fid or face_id[y1, x0] != fid:
        return False
    for k in range(1, 4):  # anything standing in between
        t = np.float32(0.25 * k)
        qx = _index(min(max(np.float32(x) + t * lx + np.float32(0.5), zero), wm))
        qy = _index(min(max(np.float32(y) + t * ly + np.float32(0.5), zero), hm))
        if face_id[qy, qx] != fid:
            return False
    return True


@njit(cache=True, nogil=True, fastmath=_FM)
def _plan_depth(depth, face_id, flat_faces, inv_cos, travel, cx, foe_row, max_step):
    """:func:`_plan` with ``s = travel / max(X - travel, travel)`` from the depth map
    (``X = depth / inv_cos``, :func:`simroad.camera._sensor_ops.motion_blur_scale`),
    for the pixels with ``face_id >= 0`` only. With ``flat_faces``, a pixel whose
    flow segment stays on its own face (:func:`_stays_on_face`) is left as it is: a
    face is flat-coloured, so the mean along the segment is the pixel's own colour."""
    h, w = depth.shape
    xs, ns, fxs, fys, row_ptr = _empty_plan(h, w)
    k, most = 0, 0
    for y in range(h):
        dv = np.float32(y - foe_row)
        for x in range(w):
            fid = face_id[y, x]
            if fid < 0:
                continue
            du = np.float32(x - cx)
            forward = depth[y, x] / inv_cos[x]
            s = travel / max(forward - travel, travel)
            length = _blur_length(s, du, dv)
            if not length >= 0.5:
                continue
            # Most face pixels blur within their face: test that before the doublings.
            if flat_faces and _stays_on_face(face_id, fid, x, y, s * du, s * dv):
                continue
            n, fx, fy = _plan_steps(s, du, dv, length, max_step)
            xs[k], ns[k], fxs[k], fys[k] = x, n, fx, fy
            k += 1
            most = max(most, n)
        row_ptr[y + 1] = k
    return xs, ns, fxs, fys, row_ptr, most


@njit(cache=True, nogil=True)
def face_share(face_id):
    """The fraction of the face map's (int32 (H, W)) pixels that show a face (id >= 0),
    estimated on every 4th row and column (what it decides is only how to plan)."""
    h, w = face_id.shape
    n, total = 0, 0
    for y in range(0, h, 4):
        row = face_id[y]
        for x in range(0, w, 4):
            n += row[x] >= 0
            total += 1
    return n / max(total, 1)


@njit(cache=True, nogil=True)
def face_edges(face_id, out):
    """``out[y, x] = 1`` (uint8) where pixel ``(x, y)``'s face id (int32 (H, W)) differs
    from its right or its lower neighbour's, else 0. Where a box of pixels holds none
    of these, the whole box shows one face (it is connected): dilated by a radius
    ``r`` (``cv2.dilate``), a 0 says the box of radius ``r`` about the pixel does."""
    h, w = face_id.shape
    for y in range(h):
        a, b, o = face_id[y], face_id[min(y + 1, h - 1)], out[y]
        for x in range(w - 1):
            o[x] = (a[x] != a[x + 1]) | (a[x] != b[x])
        o[w - 1] = a[w - 1] != b[w - 1]


@njit(cache=True, nogil=True, fastmath=_FM, error_model="numpy")
def _row_tests(frow, drow, near_a, near_b, inv_cos, dus, travel, dv, s_out, length_out, test):
    """One row of :func:`_plan_flat`, vectorised: each pixel's expansion ``s`` and blur
    length (:func:`_plan_depth`'s arithmetic) and whether it needs the face test: a
    face pixel that blurs half a pixel or more, unless its segment stays in a box
    about it that shows its face alone (``near_a``, ``near_b``: 0 where the box of
    radius :data:`NEAR_RADII` does; every tap of :func:`_stays_on_face` lies within
    one pixel more than the segment's reach)."""
    ra, rb = np.float32(NEAR_RADII[0] - 1), np.float32(NEAR_RADII[1] - 1)
    for x in range(frow.size):
        du = dus[x]
        forward = drow[x] / inv_cos[x]
        s = travel / max(forward - travel, travel)
        length = _blur_length(s, du, dv)
        reach = max(abs(s * du), abs(s * dv))
        leaves = ((reach > ra) | (near_a[x] != 0)) & ((reach > rb) | (near_b[x] != 0))
        s_out[x], length_out[x] = s, length
        test[x] = (frow[x] >= 0) & (length >= 0.5) & leaves


@njit(cache=True, nogil=True, fastmath=_FM, error_model="numpy")
def _plan_flat(depth, face_id, near_a, near_b, inv_cos, travel, cx, foe_row, max_step):
    """:func:`_plan_depth` with flat faces, the same plan (for ``travel > 0``), faster:
    the arithmetic of a row is vectorised (:func:`_row_tests`) and a pixel whose
    segment stays in a box of its face alone (the near-edge maps ``near_a``,
    ``near_b``, uint8 (H, W), :func:`face_edges` dilated by :data:`NEAR_RADII`) skips
    the face test, which it would pass."""
    h, w = depth.shape
    xs, ns, fxs, fys, row_ptr = _empty_plan(h, w)
    dus = np.empty(w, np.float32)
    for x in range(w):
        dus[x] = np.float32(x - cx)
    s_row, length_row, test = np.empty(w, np.float32), np.empty(w, np.float32), np.empty(w, np.bool_)
    k, most = 0, 0
    for y in range(h):
        dv = np.float32(y - foe_row)
        _row_tests(face_id[y], depth[y], near_a[y], near_b[y], inv_cos, dus, travel, dv, s_row, length_row, test)
        for x in range(w):
            if not test[x]:
                continue
            s, du = s_row[x], dus[x]
            if _stays_on_face(face_id, face_id[y, x], x, y, s * du, s * dv):
                continue
            n, fx, fy = _plan_steps(s, du, dv, length_row[x], max_step)
            xs[k], ns[k], fxs[k], fys[k] = x, n, fx, fy
            k += 1
            most = max(most, n)
        row_ptr[y + 1] = k
    return xs, ns, fxs, fys, row_ptr, most


@njit(cache=True, nogil=True, fastmath=_FM)
def _level_row(img, y, j, xs, ns, fxs, fys, k0, k1, tmp):
    """Level ``j`` of the planned pixels ``k0 .. k1`` of row ``y``, into ``tmp`` and then
    the image (the row's reads all see the previous level)."""
    h, w = img.shape[0], img.shape[1]
    step = np.float32(1 << j)
    wm, hm = np.float32(w - 1), np.float32(h - 1)
    yf = np.float32(y)
    for k in range(k0, k1):
        if ns[k] <= j:
            continue
        x = xs[k]
        qx = min(max(np.float32(x) + step * fxs[k], np.float32(0.0)), wm)
        qy = min(max(yf + step * fys[k], np.float32(0.0)), hm)
        x0, y0 = _index(qx), _index(qy)  # unsigned: no wrap-around test per index
        ax, ay = qx - np.float32(np.int64(x0)), qy - np.float32(np.int64(y0))  # small integers: exact
        x1, y1 = min(x0 + np.uint64(1), np.uint64(w - 1)), min(y0 + np.uint64(1), np.uint64(h - 1))
        i = k - k0
        for c in range(3):
            top = img[y0, x0, c] + ax * (img[y0, x1, c] - img[y0, x0, c])
            bot = img[y1, x0, c] + ax * (img[y1, x1, c] - img[y1, x0, c])
            tmp[i, c] = np.float32(0.5) * (img[y, x, c] + top + ay * (bot - top))
    for k in range(k0, k1):
        if ns[k] > j:
            x, i = xs[k], k - k0
            for c in range(3):
                img[y, x, c] = tmp[i, c]


@njit(cache=True, nogil=True, fastmath=_FM)
def _run_levels(img, plan, foe_row):
    xs, ns, fxs, fys, row_ptr, most = plan
    h, w = img.shape[0], img.shape[1]
    tmp = np.empty((w, 3), np.float32)
    first_below = min(max(int(math.floor(foe_row)) + 1, 0), h)
    for j in range(most):
        for y in range(first_below, h):  # below the horizon: outwards = downwards
            if row_ptr[y + 1] > row_ptr[y]:
                _level_row(img, y, j, xs, ns, fxs, fys, row_ptr[y], row_ptr[y + 1], tmp)
        for y in range(first_below - 1, -1, -1):  # above it: upwards
            if row_ptr[y + 1] > row_ptr[y]:
                _level_row(img, y, j, xs, ns, fxs, fys, row_ptr[y], row_ptr[y + 1], tmp)
    return most


@njit(cache=True, nogil=True, fastmath=_FM)
def radial_blur(img, scale, cx, foe_row, max_step):
    """Blur ``img`` (float32 (H, W, 3), C-contiguous) in place along the radial flow.

    ``scale`` is the relative expansion ``s`` per pixel (float32 (H, W)), ``(cx,
    foe_row)`` the focus of expansion in pixels, ``max_step`` the largest tap spacing in
    pixels. Returns the number of levels of the longest blur (0: nothing moved).
    """
    plan = _plan(scale, np.float32(cx), np.float32(foe_row), np.float32(max_step))
    return _run_levels(img, plan, foe_row)


@njit(cache=True, nogil=True, fastmath=_FM)
def radial_blur_depth(img, depth, face_id, flat_faces, inv_cos, travel, cx, foe_row, max_step):
    """:func:`radial_blur` of the pixels with ``face_id >= 0`` (int32 (H, W)), the
    expansion from the depth map (float32 (H, W), ``inf`` for the sky), the columns'
    ``1 / cos`` of their bearing (float32 (W,)) and the travel during the exposure (m);
    ``flat_faces`` skips the pixels whose blur stays on their own flat face."""
    plan = _plan_depth(
        depth,
        face_id,
        flat_faces,
        inv_cos,
        np.float32(travel),
        np.float32(cx),
        np.float32(foe_row),
        np.float32(max_step),
    )
    return _run_levels(img, plan, foe_row)


@njit(cache=True, nogil=True)
def _rows_read(plan, h):
    """Which rows the levels read: for each planned pixel, the rows between its own
    and its longest tap's (2**(n - 1) tap spacings along the flow), one more each side."""
    ns, fys, row_ptr = plan[1], plan[3], plan[4]
    need = np.zeros(h, np.bool_)
    for y in range(h):
        lo, hi = y, y
        for k in range(row_ptr[y], row_ptr[y + 1]):
            end = y + np.float64(1 << (ns[k] - 1)) * np.float64(fys[k])
            lo = min(lo, int(math.floor(end)))
            hi = max(hi, int(math.floor(end)) + 1)
        if row_ptr[y + 1] > row_ptr[y]:
            for r in range(max(lo - 1, 0), min(hi + 2, h)):
                need[r] = True
    return need


@njit(cache=True, nogil=True, fastmath=_FM)
def radial_blur_frame(frame, table, img, depth, face_id, near, inv_cos, travel, cx, foe_row, max_step):
    """:func:`radial_blur_depth` with flat faces, from the 8-bit ``frame`` (uint8
    (H, W, 3)), for ``travel > 0``: only the rows the blur reads are decoded (through
    ``table``) into ``img``, the rest of ``img`` is left as it was. ``near``: the two
    near-edge maps of :func:`_plan_flat`, or two empty arrays to plan with
    :func:`_plan_depth` (the same plan). Returns those rows (bool (H,)):
    each holds the decoded frame with the blurred pixels over it, every row with a
    blurred pixel is one of them (see :func:`simroad.camera._sensor_kernel.expose_frame`)."""
    args = (np.float32(travel), np.float32(cx), np.float32(foe_row), np.float32(max_step))
    if near[0].shape == depth.shape:
        plan = _plan_flat(depth, face_id, near[0], near[1], inv_cos, *args)
    else:
        plan = _plan_depth(depth, face_id, True, inv_cos, *args)
    h = frame.shape[0]
    need = _rows_read(plan, h)
    for y in range(h):
        if need[y]:
            decode(frame[y], table, img[y])
    _run_levels(img, plan, foe_row)
    return need
