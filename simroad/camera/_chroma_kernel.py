"""The chroma stage's per-pixel passes around its Gaussian (numba, ``cache=True``).

:func:`simroad.camera.exposure.process_chroma` smooths the chroma ``c - Y`` of the
encoded frame with OpenCV's Gaussian and adds it back, scaled, onto the luma. The
steps on either side of the Gaussian are one flat loop each here instead of five
numpy passes over a float32 frame: the same float32 operations in the same order (no
``fastmath``), so the frame is bit for bit the numpy one (a test holds them to it).
The luma is spread once to the frame's three channels (``luma3``) so that both loops
run over contiguous memory and LLVM vectorises them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["chroma_merge", "chroma_split"]


@njit(cache=True, nogil=True)
def chroma_split(out: np.ndarray, luma: np.ndarray, chroma: np.ndarray, luma3: np.ndarray) -> None:
    """``luma3 = float32(luma)`` per channel and ``chroma = float32(out) - luma3``.

    ``out`` uint8 (H, W, 3), ``luma`` uint8 (H, W), ``chroma`` and ``luma3`` float32
    (H, W, 3); all C-contiguous.
    """
    lu, o, ch, l3 = luma.reshape(-1), out.reshape(-1), chroma.reshape(-1), luma3.reshape(-1)
    for p in range(lu.size):
        g = np.float32(lu[p])
        l3[3 * p] = g
        l3[3 * p + 1] = g
        l3[3 * p + 2] = g
    for i in range(o.size):
        ch[i] = np.float32(o[i]) - l3[i]


@njit(cache=True, nogil=True)
def chroma_merge(chroma: np.ndarray, luma3: np.ndarray, factor: np.float32, out: np.ndarray) -> None:
    """``out = uint8(rint(clip(chroma * factor + luma3, 0, 255)))`` (rounding half to even)."""
    o, ch, l3 = out.reshape(-1), chroma.reshape(-1), luma3.reshape(-1)
    lo, hi = np.float32(0.0), np.float32(255.0)
    for i in range(o.size):
        v = min(max(ch[i] * factor + l3[i], lo), hi)
        o[i] = np.uint8(np.int32(np.rint(v)))
