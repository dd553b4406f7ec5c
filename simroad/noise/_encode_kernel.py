"""Encoding the few pixels a stage changed, exactly as :func:`~simroad.core.radiometry.linear_to_srgb` does.

The runner encodes the whole linear frame after every model (a few hundred microseconds
at 320x180). A stage that changes only some pixels (the drops on the windscreen: a
fifth of the frame) marks them in ``FrameState.touched``, and the runner encodes
those only (:func:`encode_touched`), keeping the previous encoding elsewhere.

The encoding of one float32 value is read from two tables indexed by the top 16 bits
of its bit pattern (sign, exponent and 7 bits of mantissa: a bucket spans 2^-7 of its
value, less than one grey level of ``255 x^(1/2.2)`` anywhere): the level at the
bucket's start, and the first bit pattern in the bucket one level up. The tables are
made from ``linear_to_srgb`` itself (:func:`encode_tables`, a bisection per bucket),
so the two agree bit for bit (on values below 1e15, where ``linear_to_srgb`` overflows
to 0); the tests check it on every level's step and on random values.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from simroad.core.radiometry import linear_to_srgb

__all__ = ["encode_tables", "encode_touched"]

#: Buckets below 2.0 (bit pattern 0x40000000); every value from 2.0 up encodes to 255.
_BUCKETS = 0x40000000 >> 16


@lru_cache(maxsize=1)
def encode_tables() -> tuple[np.ndarray, np.ndarray]:
    """``(level, step)``: per bucket of float32 bit patterns, the uint8 level of its first
    value under ``linear_to_srgb``, and the first bit pattern (int64) in it that encodes one
    level higher (the bucket's end when none does)."""

    def enc(bits: np.ndarray) -> np.ndarray:
        x = bits.astype(np.uint32).view(np.float32)
        pad = (-x.size) % 3
        return linear_to_srgb(np.concatenate([x, np.zeros(pad, np.float32)]).reshape(-1, 1, 3)).ravel()[: x.size]

    start = np.arange(_BUCKETS, dtype=np.int64) << 16
    level = enc(start)
    target = level.astype(np.int64) + 1
    lo, hi = np.zeros(_BUCKETS, np.int64), np.full(_BUCKETS, 1 << 16, np.int64)  # offsets in the bucket
    while (lo < hi).any():
        mid = (lo + hi) // 2
        up = enc(start + np.minimum(mid, (1 << 16) - 1)).astype(np.int64) >= target
        hi, lo = np.where(up, mid, hi), np.where(up, lo, mid + 1)
    return level, start + hi


@njit(cache=True, nogil=True)
def _encode_touched(
    lin: np.ndarray,
    touched: np.ndarray,
    enc: np.ndarray,
    changed: np.ndarray,
    threshold: int,
    level: np.ndarray,
    step: np.ndarray,
) -> None:
    bits = lin.reshape(-1).view(np.int32)
    out = enc.reshape(-1)
    n_buckets = level.size
    n = touched.size
    words = touched[: n - n % 8].view(np.uint64)
    for w in range((n + 7) // 8):
        if w < words.size and words[w] == 0:
            continue  # 8 untouched pixels
        for p in range(8 * w, min(8 * w + 8, n)):
            if not touched[p]:
                continue
            most = 0
            for c in range(3):
                x = max(bits[3 * p + c], 0)  # negative values encode as 0, as linear_to_srgb's floor does
                b = x >> 16
                if b >= n_buckets:
                    new = 255
                else:
                    new = int(level[b]) + int(x >= step[b])
                most = max(most, abs(new - int(out[3 * p + c])))
                out[3 * p + c] = new
            changed[p] = most >= threshold


def encode_touched(
    lin: np.ndarray, touched: np.ndarray, previous: np.ndarray, threshold: int
) -> tuple[np.ndarray, np.ndarray]:
    """The uint8 encoding of ``lin`` where ``touched``, ``previous`` elsewhere, and where it
    differs from ``previous`` by ``>= threshold`` levels on any channel.

    Parameters
    ----------
    lin : ndarray float32 (H, W, 3)
        The linear frame (C-contiguous).
    touched : ndarray bool (H, W)
        The pixels changed since ``previous`` was encoded from it.
    previous : ndarray uint8 (H, W, 3)
        ``linear_to_srgb`` of the frame before the change.
    threshold : int
        Grey levels (:func:`~simroad.core.radiometry.change_mask`'s).

    Returns
    -------
    enc : ndarray uint8 (H, W, 3)
        Equal to ``linear_to_srgb(lin)``.
    changed : ndarray bool (H, W)
        Equal to ``change_mask(previous, enc, threshold)``.
    """
    level, step = encode_tables()
    enc = previous.copy()
    changed = np.zeros(touched.shape, bool)
    _encode_touched(
        np.ascontiguousarray(lin), touched.reshape(-1), enc, changed.reshape(-1), int(threshold), level, step
    )
    return enc, changed
