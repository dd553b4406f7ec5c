"""Motion blur of the ground, done in the world's texture.

A camera that translates by ``travel`` metres along its heading during the exposure
sees, at each pixel, the ground points ``G - t * travel * heading`` for ``t`` in [0, 1]
(``G`` the point the pixel sees at the end of the exposure). On the flat ground that
is a box of constant length along one direction of the world's texture, whatever the
pixel: the renderer filters a small crop of the texture under the blurred rows with
that box (one small kernel) and warps those rows from it. That is exact for the
ground, costs one small filter however long the blur is in the image, and leaves the
sensor only the things with height to blur (:mod:`simroad.camera._blur_kernel`). The
blur runs on linear radiance (16 bit), as the light adds up on the sensor.
"""

from __future__ import annotations

import functools
import threading

import cv2
import numpy as np
from numba import njit

from simroad.camera._blur_kernel import decode, decode_rounded
from simroad.core.radiometry import linear_to_srgb, srgb_to_linear

__all__ = ["RowBlur", "blur_start_row", "box_blur_texture", "row_blur_px", "segment_kernel"]


@functools.cache
def _tables() -> tuple[np.ndarray, np.ndarray]:
    """sRGB code to linear radiance x 65535, and every 16-bit value back to its code."""

    codes = np.arange(256, dtype=np.uint8).reshape(1, 256, 1).repeat(3, axis=2)
    to_linear = np.round(srgb_to_linear(codes)[0, :, 0] * 65535.0).astype(np.uint16).reshape(1, 256)
    values = (np.arange(65536, dtype=np.float32) / 65535.0).reshape(256, 256, 1).repeat(3, axis=2)
    return to_linear, linear_to_srgb(values)[..., 0].ravel()


def row_blur_px(forward_m: np.ndarray, rows: np.ndarray, *, horizon_row: float, half_width_px: float, travel_m: float):
    """Longest ground blur (pixels) in each image row: ``s * |p - e|`` at the row's far
    corner, ``s = travel / (X - travel)`` for the row's forward ground distance ``X``
    (constant along a row of a camera without roll); 0 where the row sees no ground."""
    x = np.asarray(forward_m, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        s = np.where(np.isfinite(x), travel_m / np.maximum(x - travel_m, travel_m), 0.0)
    return s * np.hypot(half_width_px, rows - horizon_row)


class RowBlur:
    """:func:`row_blur_px` and :func:`blur_start_row` of one camera, what does not
    depend on the travel computed once (the same operations per row: the same values).

    Parameters
    ----------
    forward_m : ndarray (H,)
        Each row's forward ground distance in m, NaN where the row sees no ground.
    horizon_row, half_width_px : float
        As for :func:`row_blur_px`.
    first_ground_row : int
        As for :func:`blur_start_row`.
    """

    def __init__(self, forward_m: np.ndarray, *, horizon_row: float, half_width_px: float, first_ground_row: int):
        x = np.asarray(forward_m, dtype=np.float64)
        reach = np.hypot(half_width_px, np.arange(len(x), dtype=np.float64) - horizon_row)
        self._rows = np.flatnonzero(np.isfinite(x))
        self._x, self._reach = x[self._rows], reach[self._rows]
        self._first = int(first_ground_row)
        self._length = np.zeros(len(x))

    def __call__(self, travel_m: float) -> tuple[int, np.ndarray]:
        """:func:`blur_start_row` and :func:`row_blur_px` (a buffer reused by the next
        call) for ``travel_m``."""
        length = self._length
        length[self._rows] = travel_m / np.maximum(self._x - travel_m, travel_m) * self._reach
        return blur_start_row(length, self._first), length


def blur_start_row(length_px: np.ndarray, first_ground_row: int, threshold_px: float = 0.5) -> int:
    """First row from which every ground row's blur reaches ``threshold_px`` (the rows
    nearer the camera blur more); the frame's height when none does."""
    h = len(length_px)
    below = np.flatnonzero(length_px[first_ground_row:] < threshold_px)
    return first_ground_row + int(below[-1]) + 1 if below.size else first_ground_row if h else h


def segment_kernel(shift_texels: tuple[float, float], taps: int = 64) -> tuple[np.ndarray, tuple[int, int]]:
    """The correlation kernel of the mean over ``g + t * shift``, ``t`` in [0, 1]:
    ``taps`` evenly spaced bilinear samples, their weights summed on the texel grid.

    The shift is the same for every texel, so the whole box is one small kernel.

    Returns
    -------
    kernel : ndarray, float32, (kh, kw)
        Sums to 1 (read-only, cached by the shift to 1/1000 texel).
    anchor : (int, int)
        Its (column, row) for ``cv2.filter2D`` (the kernel's zero offset).
    """
    return _segment_kernel(round(float(shift_texels[0]), 3), round(float(shift_texels[1]), 3), int(taps))


@functools.lru_cache(maxsize=256)
def _segment_kernel(sx: float, sy: float, taps: int) -> tuple[np.ndarray, tuple[int, int]]:
    kernel, ox, oy = _segment_weights(_unit_steps(taps), sx, sy)
    kernel.flags.writeable = False
    return kernel, (-ox, -oy)


@functools.cache
def _unit_steps(taps: int) -> np.ndarray:
    return np.linspace(0.0, 1.0, taps)


@njit(cache=True, nogil=True)
def _segment_weights(t, sx, sy):  # pragma: no cover - compiled
    """The bilinear weights of the samples ``t * (sx, sy)`` summed on the texel grid,
    divided by their number, as float32 (kh, kw), and the grid's origin (ox, oy): the
    float64 operations of the numpy expressions (``np.bincount`` of the four corner
    weights, corner after corner) in their order, so the same bits."""
    n = t.size
    x0, y0, ax, ay = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        px, py = t[i] * sx, t[i] * sy
        x0[i], y0[i] = np.floor(px), np.floor(py)
        ax[i], ay[i] = px - x0[i], py - y0[i]
    ox, oy = int(x0.min()), int(y0.min())
    kw, kh = int(x0.max()) - ox + 2, int(y0.max()) - oy + 2
    acc = np.zeros(kh * kw)
    for corner in range(4):
        dx, dy = corner & 1, corner >> 1
        for i in range(n):
            k = (int(y0[i]) - oy + dy) * kw + int(x0[i]) - ox + dx
            wx = ax[i] if dx else 1 - ax[i]
            wy = ay[i] if dy else 1 - ay[i]
            acc[k] += wx * wy
    return (acc.reshape(kh, kw) / n).astype(np.float32), ox, oy


#: OpenCV filters a 16-bit image through the DFT from this many kernel taps on (a
#: float32 image from 130): below it, both sum the taps directly in float32.
_DFT_TAPS_16U = 50


def box_blur_texture(rgba: np.ndarray, shift_texels: tuple[float, float]) -> np.ndarray:
    """Mean of the colour of ``rgba`` (uint8 (h, w, 4) sRGB + any 4th channel, bilinear
    between texels) over the segment
    ``g + t * shift``, ``t`` in [0, 1], per texel ``g``, on linear radiance (border
    replicated): one ``cv2.filter2D`` with :func:`segment_kernel`, on 16-bit linear
    values. Returns uint8 (h, w, 4), the colour blurred (four channels: OpenCV warps
    them faster than three; the 4th is not meaningful); for a small kernel a view of
    this thread's scratch, which the next call overwrites.

    A small kernel runs on the 16-bit values held in float32: OpenCV's direct filter
    sums the taps in float32 for a 16-bit image as for a float32 one (the same
    products in the same order), and its float32 path is vectorised; the sums are
    then rounded and saturated as its 16-bit result is. The same numbers, several
    times faster."""
    to_linear, to_srgb = _tables()
    kernel, anchor = segment_kernel(shift_texels)
    if kernel.size < _DFT_TAPS_16U:
        lin, out, encoded = _scratch(rgba.shape)
        cv2.LUT(rgba, _linear_f32(), dst=lin)
        cv2.filter2D(lin, -1, kernel, dst=out, anchor=anchor, borderType=cv2.BORDER_REPLICATE)
        decode_rounded(out, to_srgb, encoded)
        return encoded
    encoded = np.empty(rgba.shape, np.uint8)
    lin = cv2.LUT(rgba, to_linear)
    out16: np.ndarray = cv2.filter2D(lin, -1, kernel, anchor=anchor, borderType=cv2.BORDER_REPLICATE)  # uint16
    decode(out16, to_srgb, encoded)  # np.take(to_srgb, out16), without its index conversion
    return encoded


_SCRATCH = threading.local()


def _scratch(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """This thread's buffers for one blur of ``shape`` (the float32 linear crop, its
    filtered copy, the uint8 result): views of arrays that grow to the largest crop
    seen. A crop's worth of new memory per frame cost as much as the filter."""
    n = int(np.prod(shape))
    bufs = getattr(_SCRATCH, "bufs", None)
    if bufs is None or bufs[0].size < n:
        bufs = _SCRATCH.bufs = (np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.uint8))
    return tuple(b[:n].reshape(shape) for b in bufs)  # type: ignore[return-value]


@functools.cache
def _linear_f32() -> np.ndarray:
    """:func:`_tables`' sRGB code to linear radiance x 65535, as float32."""
    return _tables()[0].astype(np.float32)
