"""He's guided filter (He, Sun & Tang 2013), the smoothing engine of the rain/snow
filter (paper eq. 21) and of the highlight filter's chromaticity propagation.

All window means are taken over the part of the ``(2r+1) x (2r+1)`` window that lies
inside the image (He's reference implementation), built from un-normalised
``cv2.boxFilter`` sums with a zero border divided by the per-pixel window size.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from simroad.core.validation import check_array, check_image, check_in_range, check_int_in_range
from simroad.errors import InvalidParameterError

__all__ = ["box_mean", "guided_filter"]

_MAX_RADIUS = 4096
#: OpenCV's box filter handles at most this many channels.
_MAX_CHANNELS = 128


@functools.lru_cache(maxsize=16)
def _inv_window_counts(h: int, w: int, radius: int) -> np.ndarray:
    """``1 / |w_i|``: inverse number of in-image pixels of every window, (H, W) float32."""
    rows = np.minimum(np.arange(h) + radius, h - 1) - np.maximum(np.arange(h) - radius, 0) + 1
    cols = np.minimum(np.arange(w) + radius, w - 1) - np.maximum(np.arange(w) - radius, 0) + 1
    inv = (1.0 / np.outer(rows, cols)).astype(np.float32)
    inv.setflags(write=False)
    return inv


def _box_sum(x: np.ndarray, radius: int) -> np.ndarray:
    k = 2 * radius + 1
    s = cv2.boxFilter(x, -1, (k, k), normalize=False, borderType=cv2.BORDER_CONSTANT)
    return s.reshape(x.shape)  # OpenCV drops a trailing singleton channel axis


def box_mean(x: np.ndarray, radius: int) -> np.ndarray:
    """Mean of ``x`` over each pixel's ``(2r+1) x (2r+1)`` window clipped to the image.

    Parameters
    ----------
    x : ndarray, float32 or float64, (H, W) or (H, W, C)
        Finite values, any range; at most 128 channels.
    radius : int
        Window radius ``r`` in pixels, in ``[0, 4096]`` (0 returns ``x``'s values).

    Returns
    -------
    ndarray, same shape as ``x``; float32 for a float32 ``x``, else float64
    """
    x = check_array("x", x, dtype=("float32", "float64"), ndim=(2, 3))
    if x.ndim == 3 and x.shape[2] > _MAX_CHANNELS:
        raise InvalidParameterError(
            f"x: expected at most {_MAX_CHANNELS} channels, got shape {x.shape}. Filter the channels in groups."
        )
    radius = check_int_in_range("radius", radius, 0, _MAX_RADIUS)
    inv = _inv_window_counts(x.shape[0], x.shape[1], radius)
    return _box_sum(x, radius) * (inv[..., None] if x.ndim == 3 else inv)


def _guide_stats(guide: np.ndarray, radius: int, eps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(1/|w|, mu_k, 1/(sigma_k^2 + eps))`` of a guide, reusable for many planes."""
    inv = _inv_window_counts(guide.shape[0], guide.shape[1], radius)
    mean_i = _box_sum(guide, radius) * inv
    var_i = _box_sum(guide * guide, radius) * inv
    var_i -= mean_i * mean_i
    np.maximum(var_i, 0.0, out=var_i)
    var_i += np.float32(eps)
    return inv, mean_i, 1.0 / var_i


def _coefficients(guide: np.ndarray, planes: list[np.ndarray], radius: int, eps: float, stats=None):
    """Window-averaged coefficients ``(abar, bbar)`` of eq. 21 for each plane of src."""
    inv, mean_i, inv_var = _guide_stats(guide, radius, eps) if stats is None else stats
    coefs = []
    for p in planes:
        mean_p = _box_sum(p, radius) * inv
        a = _box_sum(guide * p, radius) * inv
        a -= mean_i * mean_p
        a *= inv_var  # eq. 21: a_k = cov_k(I, p) / (sigma_k^2 + eps)
        mean_p -= a * mean_i  # b_k = pbar_k - a_k mu_k
        a_bar = _box_sum(a, radius) * inv
        b_bar = _box_sum(mean_p, radius) * inv
        coefs.append((a_bar, b_bar))
    return coefs


def _guided_planes(
    guide: np.ndarray, planes: list[np.ndarray], radius: int, eps: float, *, stats=None, subsample: int = 1
) -> list[np.ndarray]:
    """Guided filter of float32 (H, W) planes by a float32 (H, W) guide; no input checks.

    ``stats`` are the guide's :func:`_guide_stats`, to reuse when the same guide
    filters several images. With ``subsample = s > 1`` the coefficients are computed
    on an ``s``-times smaller image with radius ``r / s`` and bilinearly upsampled
    (He & Sun's fast guided filter, 2015); the output still follows the
    full-resolution guide.
    """
    h, w = guide.shape
    if subsample > 1 and min(h, w) >= 2 * subsample:
        size = (max(1, w // subsample), max(1, h // subsample))
        small = [cv2.resize(x, size, interpolation=cv2.INTER_AREA) for x in [guide, *planes]]
        r = max(1, int(round(radius / subsample)))
        coefs = [
            tuple(cv2.resize(c, (w, h), interpolation=cv2.INTER_LINEAR) for c in ab)
            for ab in _coefficients(small[0], small[1:], r, eps)
        ]
    else:
        coefs = _coefficients(guide, planes, radius, eps, stats)
    out = []
    for a_bar, b_bar in coefs:
        a_bar *= guide
        a_bar += b_bar  # q_i = abar_i I_i + bbar_i
        out.append(a_bar)
    return out


def guided_filter(guide: np.ndarray, src: np.ndarray, radius: int, eps: float, *, subsample: int = 1) -> np.ndarray:
    """He's guided filter of ``src`` steered by a grey ``guide`` (paper eq. 21).

    For every window ``w_k`` of ``(2r+1) x (2r+1)`` pixels (clipped to the image)::

        a_k = (mean_k(I p) - mu_k pbar_k) / (sigma_k^2 + eps)
        b_k = pbar_k - a_k mu_k
        q_i = abar_i I_i + bbar_i

    where ``mu_k``, ``sigma_k^2`` are the mean and variance of the guide ``I`` in
    ``w_k``, ``pbar_k`` the mean of ``src`` there, and ``abar_i``, ``bbar_i`` the means of
    ``a``, ``b`` over the windows containing pixel ``i``.

    Parameters
    ----------
    guide : ndarray, float32, (H, W)
        Guidance image ``I`` in [0, 1]. A colour guide is not supported: pass a grey
        image (e.g. the channel mean).
    src : ndarray, float32, (H, W) or (H, W, C)
        Image ``p`` to filter, values in [0, 1]; each channel is filtered with the
        same guide.
    radius : int
        Window radius ``r`` in pixels (window ``2r+1``), ``>= 1``.
    eps : float
        Regularisation ``epsilon`` in squared intensity units, ``> 0``; larger values
        smooth more (edges with ``sigma^2 << eps`` are flattened).
    subsample : int, optional
        ``1`` (default) computes the filter exactly. ``s > 1`` computes the
        coefficients on an ``s``-times smaller image and upsamples them (He & Sun's
        fast guided filter): about ``s^2`` times less box filtering, slightly softer.

    Returns
    -------
    ndarray, float32, same shape as ``src``
        The filtered image ``q``. It is not clipped: a guided filter may overshoot
        [0, 1] slightly near strong edges.
    """
    guide = check_image("guide", guide, dtype="float32", channels=0)
    src = check_image("src", src, dtype="float32", channels=None)
    if src.shape[:2] != guide.shape:
        raise InvalidParameterError(
            f"src: expected the height and width of guide {guide.shape}, got shape {src.shape}. "
            "Resize one of them so both cover the same pixels."
        )
    radius = check_int_in_range("radius", radius, 1, _MAX_RADIUS)
    eps = check_in_range("eps", eps, 0.0, 1e6, low_inclusive=False)
    subsample = check_int_in_range("subsample", subsample, 1, 16)
    if src.ndim == 2:
        return _guided_planes(guide, [src], radius, eps, subsample=subsample)[0]
    planes = list(np.ascontiguousarray(src.transpose(2, 0, 1)))
    return np.stack(_guided_planes(guide, planes, radius, eps, subsample=subsample), axis=-1)
