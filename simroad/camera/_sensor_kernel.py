"""The sensor's fused per-pixel pass: exposure, EMVA 1288 noise, ADC and response, to uint8.

One compiled pass over the pixels (numba, ``cache=True``; the first call of a fresh
install compiles for a few seconds and writes the cache next to this module) that
does, from linear radiance, what :func:`simroad.camera._sensor_ops.add_noise_dn` and
:func:`~simroad.camera._sensor_ops.adc_response_lut` describe (their OpenCV/numpy
versions are the reference the tests hold it to):

- vignetting gain times exposure (DN at full well), clipped at the full well;
- EMVA 1288 noise ``sqrt(K mu + (K sigma_read)^2)`` times the noise field's window;
- rounding, saturation at full scale, and the ADC-to-8-bit response table.

It runs row by row: the exposure, noise and rounding loop over a row is branch-free
so that LLVM vectorises it; the decode (256-entry table) and the 12-bit to 8-bit
table lookup are separate gather loops. The input is either the 8-bit frame (decoded
on the fly) or a linear float32 frame (after the motion blur). ``parallel=False``:
the simulation's workers already use every core.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

__all__ = ["expose_frame"]

_FM = {"reassoc", "contract", "nsz", "arcp"}  # no "nnan"/"ninf" assumptions
_METER_ONE = 256.0  # the metering sum's fixed point: 1/256 DN


@njit(cache=True, nogil=True, fastmath=_FM)
def _expose_row(
    buf: np.ndarray,
    vig: np.ndarray,
    scale: float,
    cap: float,
    normal: np.ndarray,
    noise: tuple[float, float, float],
    dn: np.ndarray,
) -> int:
    """Exposure, clip at the full well, EMVA 1288 noise, rounding and saturation of one row.

    Returns the row's exposed signal summed in fixed point (1/256 DN, int64): integer
    addition is associative, so the sum is the same whatever order the vectorised loop
    adds in (a float sum with ``reassoc`` was not: a freshly compiled kernel and one
    loaded from numba's cache differed in the last bit, and the auto-exposure with it).
    Each term is truncated to int32 first (``s`` is at most full scale, 65535 DN, so
    ``256 s`` fits): the same integer as a direct conversion to int64, but AVX2 converts
    float32 to int32 eight at a time and has no vector conversion to int64, which left
    the loop half scalar.
    """
    sign, k_shot, floor = noise
    g, top, ks, fl, sg = np.float32(scale), np.float32(cap), np.float32(k_shot), np.float32(floor), np.float32(sign)
    total = np.int64(0)
    for i in range(buf.size):
        s = min(buf[i] * vig[i] * g, top)
        total += np.int64(np.int32(s * np.float32(_METER_ONE)))
        s += math.sqrt(ks * s + fl) * sg * normal[i]
        dn[i] = np.int32(min(max(s, np.float32(0.0)), top) + np.float32(0.5))
    return total  # type: ignore[return-value]  # an int64 scalar


def _fill_row(src: np.ndarray, decode: np.ndarray, buf: np.ndarray) -> None:
    """One row of the input as linear radiance: decoded through ``decode`` (uint8) or copied."""


@overload(_fill_row, jit_options={"cache": True, "nogil": True})  # type: ignore[typeddict-unknown-key]
def _fill_row_impl(src, decode, buf):
    if isinstance(src.dtype, types.Integer):

        def decode_row(src, decode, buf):
            for i in range(src.size):
                buf[i] = decode[src[i]]

        return decode_row

    def copy_row(src, decode, buf):
        buf[:] = src

    return copy_row


@njit(cache=True, nogil=True)
def _lookup_row(dn: np.ndarray, table: np.ndarray, out: np.ndarray) -> None:
    for i in range(dn.size):
        out[i] = table[np.uint64(dn[i])]  # dn >= 0: unsigned, no wrap-around test


@njit(cache=True, nogil=True)
def _gain_row(vig: np.ndarray, wb: np.ndarray, out: np.ndarray) -> None:
    """One row's relative gain per channel value: ``vig[x] * wb[c]`` (float32), the
    product numpy forms for the whole (H, W, 3) map, one row at a time."""
    for x in range(vig.size):
        for c in range(3):
            out[3 * x + c] = vig[x] * wb[c]


@njit(cache=True, nogil=True)
def expose_frame(
    frame: np.ndarray,
    decode: np.ndarray,
    vig: np.ndarray,
    wb: np.ndarray,
    expo: tuple[float, float],
    field: np.ndarray,
    noise: tuple[int, int, float, float, float],
    table: np.ndarray,
    out: np.ndarray,
    meter_from: int,
    blurred: tuple[np.ndarray, np.ndarray],
    gain_rw: np.ndarray,
    gain: np.ndarray,
) -> float:
    """Expose one frame into ``out``; returns the sum of the exposed signal (DN) over
    the rows from ``meter_from`` on (the auto-exposure's metering window).

    Parameters
    ----------
    frame : ndarray, uint8 or float32, (H, W, 3)
        The sRGB frame (decoded through ``decode``) or linear radiance; C-contiguous.
    decode : ndarray, float32, (256,)
        Code to linear radiance (unused for a float32 ``frame``).
    vig : ndarray, float32, (H, W)
        Relative illumination (ones without vignetting).
    wb : ndarray, float32, (3,)
        White-balance gains; the gain of channel ``c`` at pixel ``(y, x)`` is the
        float32 product ``vig[y, x] * wb[c]``.
    expo : tuple
        ``(scale, full)``: DN per unit linear radiance on the axis, full scale in DN.
    field : ndarray, float32, (H + ph, W + pw, 3)
        Standard normals (the noise field), C-contiguous.
    noise : tuple
        ``(oy, ox, sign, k_shot, floor)``: window offset, sign, shot variance per DN
        (0 without shot noise) and read variance in DN^2; ``k_shot = floor = 0`` is
        no noise (``field`` is then not read).
    table : ndarray, uint8, (>= full + 1,)
        Digital number to the 8-bit output.
    out : ndarray, uint8, (H, W, 3)
    meter_from : int
        First row of the metering window.
    blurred : tuple
        ``(lin, rows)``: the motion blur's linear frame (float32 (H, W, 3)) and the
        rows of it to take instead of ``frame``'s (bool (H,), of length 1 for none;
        :func:`simroad.camera._blur_kernel.radial_blur_frame`): they are the frame
        decoded, with the blurred pixels over it.
    gain_rw, gain : ndarray, float32, (3W,)
        Scratch for one row's gains: one buffer, written through ``gain_rw`` and read
        through ``gain``, a read-only view of it (the exposure loop is compiled for a
        read-only gain row, the type the rows of a whole-frame map had).
    """
    h, w = frame.shape[0], frame.shape[1]
    scale, full = expo
    oy, ox, sign, k_shot, floor = noise
    noisy = k_shot > 0.0 or floor > 0.0
    lin, rows = blurred
    patched = rows.size == h
    flat = frame.reshape(h, 3 * w)
    dst = out.reshape(h, 3 * w)
    buf = np.empty(3 * w, np.float32)
    dn = np.empty(3 * w, np.int32)
    zeros = np.zeros(3 * w, np.float32)
    total = np.int64(0)
    for y in range(h):
        if patched and rows[y]:
            row = lin[y].reshape(-1)  # decoded and blurred already
        else:
            _fill_row(flat[y], decode, buf)
            row = buf
        _gain_row(vig[y], wb, gain_rw)
        normal = field[oy + y].reshape(-1)[3 * ox : 3 * ox + 3 * w] if noisy else zeros
        row_total = _expose_row(row, gain, scale, full, normal, (sign, k_shot, floor), dn)
        if y >= meter_from:
            total += row_total
        _lookup_row(dn, table, dst[y])
    return total / _METER_ONE
