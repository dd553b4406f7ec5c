"""The SVM tabulated over quantised colours, so a frame is classified by indexing.

The decision depends only on the pixel's colour (see :mod:`simroad.detector.features`),
so it is evaluated once for every cell of an RGB grid with ``2**bits`` levels per
channel (at the cell centre) and stored as a bool table of ``2**(3 bits)`` entries.
Classifying a 320x180 frame is then a handful of integer operations per pixel instead
of a kernel expansion over hundreds of support vectors (paper eq. 30 per pixel costs
~0.1-0.4 s a frame).

The table only differs from the exact SVM for pixels whose colour lies within half a
cell of the decision boundary; with 6 bits (cells of 4 grey levels) that is well under
1 % of the pixels of a rendered frame (``benchmarks/bench_detector.py`` prints it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["build_lut", "lut_index", "lut_lookup", "pack_lut", "unpack_lut"]

_CHUNK = 1 << 16


def cell_centres(bits: int) -> np.ndarray:
    """RGB cell centres in [0, 1] for every table index, (2**(3 bits), 3) float64.

    Index ``(r << 2b) | (g << b) | b`` of the quantised levels, as in :func:`lut_index`.
    """
    n = 1 << bits
    step = 256 // n
    levels = (np.arange(n) * step + (step - 1) / 2.0) / 255.0
    r, g, b = np.meshgrid(levels, levels, levels, indexing="ij")
    return np.stack([r.ravel(), g.ravel(), b.ravel()], axis=1)


def build_lut(decide: Callable[[np.ndarray], np.ndarray], bits: int) -> np.ndarray:
    """Tabulate ``decide`` (RGB rows in [0, 1] -> bool) at every cell centre.

    Parameters
    ----------
    decide : callable
        Maps an ``(N, 3)`` float64 array of RGB colours in [0, 1] to ``(N,)`` bool.
    bits : int
        Levels per channel are ``2**bits`` (1-8).

    Returns
    -------
    ndarray, bool, (2**(3 bits),)
    """
    centres = cell_centres(bits)
    out = np.empty(len(centres), dtype=bool)
    for s in range(0, len(centres), _CHUNK):
        out[s : s + _CHUNK] = decide(centres[s : s + _CHUNK])
    return out


def lut_index(planes: list[np.ndarray], bits: int) -> np.ndarray:
    """Table index of every pixel from its uint8 R, G, B planes (each (H, W)); (H, W) int32.

    The planes may be strided views, e.g. ``[image[..., c] for c in range(3)]``.
    """
    shift = 8 - bits
    r, g, b = (p >> shift if shift else p for p in planes)
    idx = r.astype(np.int32)
    idx <<= 2 * bits
    idx |= g.astype(np.int32) << bits
    idx |= b
    return idx


def lut_lookup(table: np.ndarray, image: np.ndarray, bits: int) -> np.ndarray:
    """Classify a uint8 RGB image (H, W, 3) by table lookup; (H, W) bool."""
    return np.take(table, lut_index([image[..., c] for c in range(3)], bits))


def pack_lut(table: np.ndarray) -> np.ndarray:
    """Bit-pack a bool table for storage (8 entries per byte), uint8."""
    return np.packbits(table)


def unpack_lut(packed: np.ndarray, bits: int) -> np.ndarray:
    """Inverse of :func:`pack_lut` for a table of ``2**(3 bits)`` entries."""
    return np.unpackbits(packed, count=1 << (3 * bits)).astype(bool)
