"""The paper's light filter: find highlights by the dark channel and reduce them to diffuse colour (eqs. 23-27).

Dichromatic model (eq. 23): ``I = w_d B + w_s G``. Highlights are found with the dark
channel (eq. 24) and Otsu's automatic threshold; inside them the specular component is
removed with the specular-to-diffuse mechanism (eq. 27)::

    I_D = I - (max_u I_u - Lambda_max * sum_u I_u) / (1 - 3 Lambda_max)

which is exact when ``Lambda_max`` is the pixel's maximum *diffuse* chromaticity and
the illuminant is white (a white-balanced camera). ``Lambda_max`` is estimated per
pixel as in Yang, Wang & Ahuja (2010): start from the pixel's own maximum chromaticity
``sigma_max = max_c I_c / sum_c I_c`` (which a highlight pulls towards 1/3) and
propagate larger values from diffuse neighbours with an edge-preserving filter whose
range kernel is the specular-invariant approximate diffuse chromaticity
``lambda_max = (sigma_max - sigma_min) / (1 - 3 sigma_min)``; keep the maximum of the
two and repeat. Yang uses a joint bilateral filter; OpenCV's headless build has no
joint bilateral (``cv2.ximgproc`` is absent) and a brute-force one costs more than
the whole detector, so we use He's guided filter of ``sigma_max`` guided by
``lambda_max`` -- also edge-preserving, made of box filters, and a small fraction of
that per pass (``make bench`` times the filters on the machine at hand).

Achromatic pixels (grey asphalt, white markings, overcast sky) have
``Lambda_max -> 1/3`` and ``1 - 3 Lambda_max -> 0``: the specular and diffuse parts
are indistinguishable there, so eq. 27 is not applied (the pixel is kept) wherever
``3 Lambda_max - 1 < achromatic_tol``. Nor is it applied to pixels that are
themselves nearly grey (``1 - 3 sigma_min < achromatic_tol``) even when a chromatic
``Lambda_max`` reached them from a neighbour: eq. 27 would call a grey pixel entirely
specular and paint it black (grey pavement next to a brown shoulder came out as
coloured speckles before this guard). The consequence, measured on
:mod:`simroad.noise` glare: a white sun glint on grey asphalt is *not* removed --
the dichromatic model cannot separate white light from a grey surface (the improved
variant, :func:`~simroad.filters.remove_glare`, handles that case).
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad.core.validation import check_array, check_in_range, check_int_in_range
from simroad.errors import InvalidParameterError
from simroad.filters._common import (
    FilterResult,
    Planes,
    channel_max,
    channel_min,
    channel_sum,
    check_filter_image,
    check_odd_size,
    crop_box,
    from_planes,
    to_planes,
)
from simroad.filters._threshold import otsu_threshold
from simroad.filters.guided import _guide_stats, _guided_planes

__all__ = ["dark_channel", "remove_highlights", "specular_to_diffuse"]

_TINY = np.float32(1e-6)


def _dark_channel(planes: list[np.ndarray], patch: int) -> np.ndarray:
    dark = channel_min(planes)
    if patch == 1:
        return dark
    # cv2.erode's default border ignores outside pixels: a window clipped to the image.
    return cv2.erode(dark, np.ones((patch, patch), np.uint8))


def dark_channel(image: np.ndarray, *, patch: int = 7) -> np.ndarray:
    """Dark channel ``I_dark(x) = min_{y in Omega(x)} min_c I^c(y)`` (paper eq. 24).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    patch : int, optional
        Side of the square window ``Omega(x)`` in pixels, odd, in [1, 255]; windows
        are clipped at the image border.

    Returns
    -------
    ndarray, (H, W), same dtype as ``image``
    """
    image = check_filter_image("image", image)
    patch = check_odd_size("patch", patch, 1, 255)
    src = image.astype(np.float32) if image.dtype == np.float64 else image
    planes = [np.ascontiguousarray(src[..., c]) for c in range(3)]
    return _dark_channel(planes, patch).astype(image.dtype, copy=False)


def _diffuse_planes(planes: list[np.ndarray], lam: np.ndarray, achromatic_tol: float) -> list[np.ndarray]:
    """Eq. 27 on float32 planes; ``lam`` (H, W) is ``Lambda_max``. Returns new planes."""
    total = channel_sum(planes)
    darkest = channel_min(planes)
    denom = 1.0 - 3.0 * lam
    tol = np.float32(achromatic_tol)
    # Guards: an achromatic diffuse colour (1 - 3 Lambda -> 0), or a pixel that is
    # itself nearly grey (1 - 3 min/sum -> 0: a grey surface or a saturated highlight).
    chromatic = (denom < -tol) & (total - 3.0 * darkest >= tol * total)
    spec = channel_max(planes) - lam * total
    spec /= np.where(chromatic, denom, np.float32(-1.0))
    # The specular part is white and non-negative, and cannot exceed the darkest channel.
    spec = np.clip(spec, 0.0, darkest)
    spec[~chromatic] = 0.0
    return [p - spec for p in planes]


def specular_to_diffuse(image: np.ndarray, lambda_max: np.ndarray, *, achromatic_tol: float = 0.1) -> np.ndarray:
    """Diffuse component by the specular-to-diffuse mechanism (paper eq. 27).

    ``I_D = I - (max_u I_u - Lambda_max sum_u I_u) / (1 - 3 Lambda_max)`` for a white
    illuminant. The specular amount is clipped to ``[0, min_c I_c]`` (it is white
    and additive) and set to 0 where ``3 Lambda_max - 1 < achromatic_tol`` (achromatic
    diffuse colour) or where the pixel itself is nearly grey,
    ``1 - 3 min_c I_c / sum_c I_c < achromatic_tol`` -- a grey surface and a
    saturated highlight look alike there, and grey asphalt is the common case.

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image ``I``.
    lambda_max : ndarray, float32 or float64, (H, W)
        Maximum diffuse chromaticity per pixel, in [1/3, 1].
    achromatic_tol : float, optional
        Guard on ``3 Lambda_max - 1`` and on the pixel's own ``1 - 3 sigma_min``
        (both 0 for grey), in [0, 1].

    Returns
    -------
    ndarray, same shape and dtype as ``image``
    """
    image = check_filter_image("image", image)
    lam = check_array("lambda_max", lambda_max, dtype=("float32", "float64"), ndim=2)
    if lam.shape != image.shape[:2]:
        raise InvalidParameterError(
            f"lambda_max: expected a float array of shape {image.shape[:2]}, got "
            f"{lam.dtype} {lam.shape}. Pass one chromaticity per pixel."
        )
    if lam.min() < 1.0 / 3.0 - 1e-6 or lam.max() > 1.0 + 1e-6:
        raise InvalidParameterError(
            f"lambda_max: expected values in [1/3, 1] (a chromaticity maximum), got [{lam.min():g}, {lam.max():g}]."
        )
    tol = check_in_range("achromatic_tol", achromatic_tol, 0.0, 1.0)
    out = _diffuse_planes(to_planes(image), lam.astype(np.float32), tol)
    return from_planes(out, image.dtype)


def _chromaticities(planes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``sigma_max = max_c I_c / sum_c I_c`` and the specular-invariant
    ``lambda_max = (sigma_max - sigma_min) / (1 - 3 sigma_min)`` (Tan & Ikeuchi), (H, W) float32."""
    total = channel_sum(planes)
    inv_total = 1.0 / np.maximum(total, _TINY)
    cmax = channel_max(planes) * inv_total
    cmin = channel_min(planes) * inv_total
    dark = total < _TINY
    cmax[dark] = 1.0 / 3.0  # black pixels: no colour information
    cmin[dark] = 1.0 / 3.0
    spread = 1.0 - 3.0 * cmin
    lam = (cmax - cmin) / np.maximum(spread, _TINY)
    lam[spread < 1e-3] = 1.0 / 3.0  # grey: undefined, taken as achromatic
    np.clip(lam, 1.0 / 3.0, 1.0, out=lam)
    return cmax, lam


def _propagate(sigma: np.ndarray, guide: np.ndarray, radius: int, eps: float, iterations: int) -> np.ndarray:
    """Yang's iteration ``sigma <- max(sigma, filter(sigma))`` with a guided filter."""
    # A guided filter can overshoot at edges; no pixel's diffuse chromaticity is
    # propagated beyond the largest chromaticity found in its neighbourhood.
    ceiling = cv2.dilate(sigma, np.ones((2 * radius + 1, 2 * radius + 1), np.uint8))
    stats = _guide_stats(guide, radius, eps)
    for _ in range(iterations):
        prop = _guided_planes(guide, [sigma], radius, eps, stats=stats)[0]
        sigma = np.maximum(sigma, np.minimum(prop, ceiling, out=prop), out=prop)
    return sigma


def _max_diffuse_chromaticity(
    planes: list[np.ndarray], radius: int, eps: float, iterations: int, subsample: int = 1
) -> np.ndarray:
    """Yang et al. (2010) estimate of ``Lambda_max`` per pixel, (H, W) float32.

    With ``subsample = s > 1`` the propagation runs on an ``s``-times smaller image
    (radius ``r / s``) and its upsampled result is combined with each pixel's own
    ``sigma_max``.
    """
    cmax, lam = _chromaticities(planes)
    h, w = cmax.shape
    if subsample > 1 and min(h, w) >= 2 * subsample:
        size = (max(1, w // subsample), max(1, h // subsample))
        r = max(1, int(round(radius / subsample)))
        small = [cv2.resize(x, size, interpolation=cv2.INTER_AREA) for x in (cmax, lam)]
        prop = cv2.resize(_propagate(small[0], small[1], r, eps, iterations), (w, h), interpolation=cv2.INTER_LINEAR)
        sigma = np.maximum(cmax, prop, out=prop)
    else:
        sigma = _propagate(cmax, lam, radius, eps, iterations)
    return np.clip(sigma, 1.0 / 3.0, 1.0)


def _highlights_planes(
    planes: Planes, *, patch: int, radius: int, eps: float, iterations: int, achromatic_tol: float, subsample: int
) -> tuple[Planes, np.ndarray]:
    """Core of :func:`remove_highlights` on float32 planes; returns (new planes, mask).

    ``Lambda_max`` is only estimated on the highlights' bounding box grown by the
    reach of the propagation (``2 r`` per pass plus ``r`` for the ceiling), which gives
    the same values inside the highlights as on the whole image.
    """
    dark = _dark_channel(planes, patch)
    mask = dark > otsu_threshold(dark)
    if not mask.any():
        return planes, mask  # no highlight: the planes themselves
    rs, cs = crop_box(mask, radius * (2 * iterations + 1))
    crop = [np.ascontiguousarray(p[rs, cs]) for p in planes]
    lam = _max_diffuse_chromaticity(crop, radius, eps, iterations, subsample)
    diffuse = _diffuse_planes(crop, lam, achromatic_tol)
    inside = mask[rs, cs]
    out = [p.copy() for p in planes]
    for o, d in zip(out, diffuse):
        np.copyto(o[rs, cs], d, where=inside)
    return out, mask


def remove_highlights(
    image: np.ndarray,
    *,
    patch: int = 7,
    radius: int = 8,
    eps: float = 1e-4,
    iterations: int = 2,
    achromatic_tol: float = 0.1,
    subsample: int = 2,
) -> FilterResult:
    """Detect highlights and reduce them to their diffuse colour (paper eqs. 24, 27).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    patch : int, optional
        Dark-channel window side in pixels (eq. 24), odd, in [1, 255].
    radius : int, optional
        Radius in pixels of the guided filter that propagates the diffuse
        chromaticity (our stand-in for Yang's joint bilateral filter), in [1, 64].
    eps : float, optional
        Its regularisation (chromaticity units squared), > 0; smaller keeps the
        propagation from crossing colour edges.
    iterations : int, optional
        Propagation passes ``Lambda <- max(Lambda, filter(Lambda))``, in [0, 10].
    achromatic_tol : float, optional
        Pixels with ``3 Lambda_max - 1 < achromatic_tol`` are left as they are.
    subsample : int, optional
        Run the propagation's guided filter on an image this many times smaller
        (He & Sun's fast guided filter), in [1, 4]; 1 is exact, the default 2 costs
        about a third.

    Returns
    -------
    FilterResult
        ``image``: same shape and dtype as the input, eq. 27 applied inside the
        highlight mask, the input elsewhere. ``mask``: bool (H, W), the highlights:
        dark channel above its Otsu threshold. A constant dark channel has no
        threshold, so the mask is empty and the image is returned unchanged.
    """
    image = check_filter_image("image", image)
    patch = check_odd_size("patch", patch, 1, 255)
    radius = check_int_in_range("radius", radius, 1, 64)
    eps = check_in_range("eps", eps, 0.0, 1.0, low_inclusive=False)
    iterations = check_int_in_range("iterations", iterations, 0, 10)
    tol = check_in_range("achromatic_tol", achromatic_tol, 0.0, 1.0)
    subsample = check_int_in_range("subsample", subsample, 1, 4)
    out, mask = _highlights_planes(
        to_planes(image), patch=patch, radius=radius, eps=eps, iterations=iterations, achromatic_tol=tol,
        subsample=subsample,
    )  # fmt: skip
    return FilterResult(from_planes(out, image.dtype), mask)
