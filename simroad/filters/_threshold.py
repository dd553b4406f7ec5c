"""Otsu's automatic threshold for float-valued maps (NDI, dark channel).

OpenCV's ``cv2.threshold(..., THRESH_OTSU)`` works on 8-bit images, so the values
are first mapped linearly onto 256 levels spanning their own range; the chosen level
is mapped back to the value scale.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["otsu_threshold"]

_LEVELS = 256


def otsu_threshold(values: np.ndarray) -> float:
    """Otsu's threshold of ``values``: the split maximising the between-class variance.

    Parameters
    ----------
    values : ndarray, float, any shape
        Finite values (the caller validates them).

    Returns
    -------
    float
        Threshold ``T`` in the units of ``values``: ``values > T`` is the upper class.
        The values are histogrammed on 256 equal bins between their minimum and
        maximum; ``T`` sits halfway between the last bin of the lower class and the
        first bin of the upper one. A constant (or empty) input has no split and
        returns its maximum, so ``values > T`` selects nothing.
    """
    if values.size == 0:
        return 0.0
    lo, hi = float(values.min()), float(values.max())
    if not hi - lo > 1e-12 * max(1.0, abs(hi)):
        return hi
    levels = quantize_levels(values, lo, hi)
    t, _ = cv2.threshold(levels, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return lo + (float(t) + 0.5) * (hi - lo) / (_LEVELS - 1)


def quantize_levels(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Map ``values`` in ``[lo, hi]`` linearly onto uint8 levels 0-255 (rounded), as (1, N)."""
    scale = (_LEVELS - 1) / (hi - lo)
    flat = np.asarray(values, dtype=np.float32).reshape(1, -1)
    return cv2.convertScaleAbs(flat, alpha=scale, beta=-lo * scale)
