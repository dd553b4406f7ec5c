"""The SVM tabulated over colours, so a frame is classified by indexing.

The decision depends only on the pixel's colour (see :mod:`simroad.detector.features`),
so it is evaluated once per colour and stored. A full table of the 2**24 8-bit colours
would cost 16.7 M kernel expansions to build; instead :class:`ColourTable` has two
levels:

1. a coarse grid of ``2**bits`` levels per channel (262 144 cells for 6 bits), the
   decision taken at each cell centre;
2. for every cell near the decision boundary -- one whose decision differs from one of
   its 26 neighbours' -- the decision for each of the ``(256 / 2**bits)**3`` 8-bit
   colours inside it (64 for 6 bits).

Cells away from the boundary hold one class throughout (the RBF decision function is
smooth on the scale of a few grey levels), so the table reproduces the SVM exactly
for 8-bit colours; the tests and ``benchmarks/bench_detector.py`` check that against
scikit-learn's ``SVC.predict``. Classifying a 320x180 frame is then a few integer
operations per pixel instead of a kernel expansion over hundreds of support vectors
(paper eq. 30 per pixel is two orders of magnitude slower; ``make bench`` measures
both).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from simroad.detector._lookup_kernel import lookup_planes

__all__ = ["ColourTable", "cell_centres", "lut_index"]

_CHUNK = 1 << 16


def cell_centres(bits: int) -> np.ndarray:
    """RGB cell centres in [0, 1] for every coarse index, (2**(3 bits), 3) float64.

    Index ``(r << 2b) | (g << b) | b`` of the quantised levels, as in :func:`lut_index`.
    """
    n = 1 << bits
    step = 256 // n
    levels = (np.arange(n) * step + (step - 1) / 2.0) / 255.0
    r, g, b = np.meshgrid(levels, levels, levels, indexing="ij")
    return np.stack([r.ravel(), g.ravel(), b.ravel()], axis=1)


def lut_index(planes: list[np.ndarray], bits: int) -> np.ndarray:
    """Coarse index of every pixel from its uint8 R, G, B planes (each (H, W)); (H, W) int32.

    The planes may be strided views, e.g. ``[image[..., c] for c in range(3)]``.
    """
    shift = 8 - bits
    r, g, b = (p >> shift if shift else p for p in planes)
    idx = r.astype(np.int32)
    idx <<= 2 * bits
    idx |= g.astype(np.int32) << bits
    idx |= b
    return idx


def _boundary_cells(coarse: np.ndarray, bits: int) -> np.ndarray:
    """Coarse cells whose decision differs from one of their 26 neighbours', ascending, (n,) int32."""
    grid = coarse.reshape((1 << bits,) * 3)
    hi = ndimage.maximum_filter(grid, size=3, mode="nearest")
    near = hi != ndimage.minimum_filter(grid, size=3, mode="nearest")
    return np.flatnonzero(near).astype(np.int32)


def _packed(arrays: Mapping[str, np.ndarray], name: str, n_bits: int) -> np.ndarray:
    """Unpack the uint8 array ``name`` holding exactly ``n_bits`` bits (a multiple of 8); (n_bits,) bool."""
    packed = _exact(arrays, name, np.uint8, (n_bits // 8,))
    return np.unpackbits(packed, count=n_bits).astype(bool)


def _exact(arrays: Mapping[str, np.ndarray], name: str, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
    a = arrays[name]
    if not isinstance(a, np.ndarray) or a.dtype != np.dtype(dtype) or a.shape != shape:
        got = f"{a.dtype} {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__
        raise ValueError(f"array {name!r} is {got}; the format needs {np.dtype(dtype)} {shape}")
    return a


def _decide_chunked(decide: Callable[[np.ndarray], np.ndarray], rgb: np.ndarray) -> np.ndarray:
    out = np.empty(len(rgb), dtype=bool)
    for s in range(0, len(rgb), _CHUNK):
        out[s : s + _CHUNK] = decide(rgb[s : s + _CHUNK])
    return out


def _fine_colours(cells: np.ndarray, bits: int) -> np.ndarray:
    """All 8-bit colours inside the given coarse cells, (len(cells) * step**3, 3) in [0, 1]."""
    step = 1 << (8 - bits)
    mask = (1 << bits) - 1
    base = np.stack([(cells >> (2 * bits)) & mask, (cells >> bits) & mask, cells & mask], axis=1) * step
    off = np.stack(np.meshgrid(*(np.arange(step),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    return ((base[:, None, :] + off[None, :, :]).reshape(-1, 3)) / 255.0


@dataclass(frozen=True)
class ColourTable:
    """A colour classifier tabulated for all 8-bit RGB colours (two-level table).

    Attributes
    ----------
    bits : int
        Coarse levels per channel are ``2**bits`` (5-7).
    coarse : ndarray, bool, (2**(3 bits),)
        Decision at each coarse cell centre.
    refined_cells : ndarray, int32, (n,)
        Coarse indices of the cells stored at full 8-bit resolution, ascending.
    fine : ndarray, bool, (n, (256 / 2**bits)**3)
        Decision for each 8-bit colour of those cells, indexed by
        ``(r % s) * s * s + (g % s) * s + (b % s)`` with ``s = 256 / 2**bits``.
    """

    bits: int
    coarse: np.ndarray
    refined_cells: np.ndarray
    fine: np.ndarray
    _flat: np.ndarray = field(init=False, repr=False, compare=False)
    _offset: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Flattened for branch-free lookup: every coarse cell points at a block of
        # step**3 entries of one array -- a shared all-False or all-True block for a
        # uniform cell, its own block for a refined one -- and a pixel reads
        # ``flat[offset[coarse index] + index within the cell]``.
        size = 1 << (3 * (8 - self.bits))
        flat = np.concatenate([np.zeros(size, bool), np.ones(size, bool), self.fine.reshape(-1)])
        offset = self.coarse.astype(np.int32) * size
        offset[self.refined_cells] = (2 + np.arange(len(self.refined_cells), dtype=np.int32)) * size
        object.__setattr__(self, "_flat", flat)
        object.__setattr__(self, "_offset", offset)

    @classmethod
    def build(cls, decide: Callable[[np.ndarray], np.ndarray], bits: int) -> ColourTable:
        """Tabulate ``decide`` (RGB rows (N, 3) in [0, 1] -> (N,) bool)."""
        coarse = _decide_chunked(decide, cell_centres(bits))
        cells = _boundary_cells(coarse, bits)
        fine = _decide_chunked(decide, _fine_colours(cells, bits)).reshape(len(cells), -1)
        return cls(bits, coarse, cells, fine)

    def lookup(self, planes: list[np.ndarray]) -> np.ndarray:
        """Classify pixels given as three (H, W) planes R, G, B; (H, W) bool.

        The planes are uint8 (strided views such as ``image[..., c]`` too), or float32
        in [0, 1], which are rounded to 8-bit levels first exactly as
        :func:`simroad.filters._common.planes_to_uint8` rounds them (the filtered
        planes of the detector go to the table without an 8-bit copy). One compiled
        pass (:mod:`simroad.detector._lookup_kernel`).
        """
        return lookup_planes(planes, self._offset, self._flat, self.bits)

    def lookup_image(self, image: np.ndarray) -> np.ndarray:
        """Classify a uint8 RGB image (H, W, 3); (H, W) bool."""
        return self.lookup([image[..., c] for c in range(3)])

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Bit-packed arrays for :func:`numpy.savez` (no pickle)."""
        return {
            "lut": np.packbits(self.coarse),
            "lut_bits": np.asarray(self.bits, dtype=np.int64),
            "lut_refined_cells": self.refined_cells,
            "lut_fine": np.packbits(self.fine.reshape(-1)),
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> ColourTable:
        """Inverse of :meth:`to_arrays`, checked exactly; raises ValueError naming the first bad array.

        Every array must have the dtype and shape :meth:`to_arrays` writes, and the
        refined cells must be exactly the coarse table's boundary cells (as
        :meth:`build` chooses them), so a damaged coarse table cannot pass.
        """
        bits_arr = _exact(arrays, "lut_bits", np.int64, ())
        bits = int(bits_arr)
        if not 5 <= bits <= 7:
            raise ValueError(f"array 'lut_bits' is {bits}; the format needs 5, 6 or 7")
        coarse = _packed(arrays, "lut", 1 << (3 * bits))
        cells = arrays["lut_refined_cells"]
        if not isinstance(cells, np.ndarray) or cells.dtype != np.int32 or cells.ndim != 1:
            got = f"{cells.dtype} {cells.shape}" if isinstance(cells, np.ndarray) else type(cells).__name__
            raise ValueError(f"array 'lut_refined_cells' is {got}; the format needs int32 (n,)")
        if not np.array_equal(cells, _boundary_cells(coarse, bits)):
            raise ValueError("array 'lut_refined_cells' does not list the boundary cells of array 'lut'")
        fine_size = 1 << (3 * (8 - bits))
        fine = _packed(arrays, "lut_fine", len(cells) * fine_size)
        return cls(bits, coarse, cells, fine.reshape(len(cells), fine_size))
