"""HSI intensity and saturation (paper eqs. 10-11), shared by the filters and the detector's features.

Both work on the per-pixel channel sum ``R + G + B`` and minimum ``min(R, G, B)`` of
float arrays in [0, 1] (any shape, float32 or float64), and keep that dtype, so the
shadow filter's NDI (float32 planes) and the SVM features (float64 rows) use the same
arithmetic.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hsi_intensity", "hsi_saturation"]


def hsi_intensity(total: np.ndarray) -> np.ndarray:
    """Intensity ``I = (R + G + B) / 3`` (eq. 10) from the channel sum.

    Parameters
    ----------
    total : ndarray, float32 or float64, any shape
        ``R + G + B`` per pixel, each channel in [0, 1].

    Returns
    -------
    ndarray, same shape and dtype as ``total``
        ``total`` times one third rounded to ``total``'s dtype; in [0, 1].
    """
    return total * total.dtype.type(1.0 / 3.0)


def hsi_saturation(total: np.ndarray, darkest: np.ndarray, *, tiny: float | np.floating) -> np.ndarray:
    """Saturation ``S = 1 - 3 min(R, G, B) / (R + G + B)`` (eq. 11).

    Parameters
    ----------
    total, darkest : ndarray, float32 or float64, same shape
        ``R + G + B`` and ``min(R, G, B)`` per pixel, each channel in [0, 1].
    tiny : float
        Pixels with ``total < tiny`` are black: saturation is 0/0 there and reported
        as 0; ``tiny`` also bounds the divisor.

    Returns
    -------
    ndarray, same shape and dtype as ``total``
        ``S`` in [0, 1]; 0 for grey and black pixels.
    """
    sat = 1.0 - 3.0 * darkest / np.maximum(total, tiny)
    sat[total < tiny] = 0.0
    return sat
