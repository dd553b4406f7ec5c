"""The colour table's per-pixel lookup, compiled: one pass from three planes to the decision.

:meth:`simroad.detector.lut.ColourTable.lookup` in one loop (numba, ``cache=True``; the
first call of a fresh install compiles for a second and writes the cache next to this
module) instead of a dozen whole-frame integer arrays. Each pixel reads
``flat[offset[coarse index] + index within the cell]`` (see :class:`ColourTable`).

The planes are uint8, or float32 in [0, 1]: a float is first rounded to its 8-bit level
exactly as :func:`simroad.filters._common.planes_to_uint8` does --
``cv2.convertScaleAbs(max(x, 0), alpha=255)``, i.e. ``min(rint(x * 255), 255)`` in
float32, round half to even (checked for every float32 in [0, 1]) -- so the filtered
frame goes to the table without an 8-bit copy.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

__all__ = ["lookup_planes"]


@njit(cache=True, nogil=True)
def _decide(rv: Any, gv: Any, bv: Any, offset: np.ndarray, flat: np.ndarray, bits: Any) -> Any:
    """The table's decision for 8-bit levels ``rv, gv, bv`` (uint64: unsigned indices need no
    wrap-around test, which halves the lookup's time)."""
    shift = np.uint64(8) - bits
    low = (np.uint64(1) << shift) - np.uint64(1)
    coarse = ((rv >> shift) << (np.uint64(2) * bits)) | ((gv >> shift) << bits) | (bv >> shift)
    sub = ((((rv & low) << shift) | (gv & low)) << shift) | (bv & low)
    return flat[np.uint64(offset[coarse]) + sub]


@njit(cache=True, nogil=True)
def _levels(row: np.ndarray, out: np.ndarray) -> None:
    """Float32 plane values as 8-bit levels, as ``planes_to_uint8`` rounds them: ``rint`` of
    ``0 <= v < 2**23`` is ``(v + 2**23) - 2**23`` in float32 (round half to even); with the
    clip to [0, 255] as selects (NaN and negatives: 0) the loop vectorises."""
    big = np.float32(8388608.0)
    for j in range(row.size):
        v = row[j] * np.float32(255.0)
        v = v if v > np.float32(0.0) else np.float32(0.0)
        v = v if v < np.float32(255.0) else np.float32(255.0)
        out[j] = np.int32((v + big) - big)


@njit(cache=True, nogil=True)
def _lookup_u8(
    r: np.ndarray, g: np.ndarray, b: np.ndarray, offset: np.ndarray, flat: np.ndarray, bits: Any, out: np.ndarray
) -> None:
    h, w = out.shape
    for i in range(h):
        for j in range(w):
            out[i, j] = _decide(np.uint64(r[i, j]), np.uint64(g[i, j]), np.uint64(b[i, j]), offset, flat, bits)


@njit(cache=True, nogil=True)
def _lookup_f32(
    r: np.ndarray, g: np.ndarray, b: np.ndarray, offset: np.ndarray, flat: np.ndarray, bits: Any, out: np.ndarray
) -> None:
    h, w = out.shape
    lr, lg, lb = np.empty(w, np.int32), np.empty(w, np.int32), np.empty(w, np.int32)
    for i in range(h):
        _levels(r[i], lr)
        _levels(g[i], lg)
        _levels(b[i], lb)
        for j in range(w):
            out[i, j] = _decide(np.uint64(lr[j]), np.uint64(lg[j]), np.uint64(lb[j]), offset, flat, bits)


def lookup_planes(planes: list[np.ndarray], offset: np.ndarray, flat: np.ndarray, bits: int) -> np.ndarray:
    """Decisions (H, W) bool of three (H, W) planes, all uint8 or all float32 in [0, 1] (views allowed)."""
    out = np.empty(planes[0].shape, np.bool_)
    kernel = _lookup_u8 if planes[0].dtype == np.uint8 else _lookup_f32
    kernel(planes[0], planes[1], planes[2], offset, flat, np.uint64(bits), out)
    return out
