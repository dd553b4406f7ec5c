"""Light-intensity (highlight) filter (paper §III-B-II, eqs. 23-27).

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
joint bilateral (``cv2.ximgproc`` is absent) and a brute-force one costs tens of ms,
so we use He's guided filter of ``sigma_max`` guided by ``lambda_max`` -- also
edge-preserving, made of box filters, and well under 1 ms per pass at 320x180.

Achromatic pixels (grey asphalt, white markings, overcast sky) have
``Lambda_max -> 1/3`` and ``1 - 3 Lambda_max -> 0``: the specular and diffuse parts
are indistinguishable there, so eq. 27 is not applied (the pixel is kept) wherever
``3 Lambda_max - 1 < achromatic_tol``. Nor is it applied to pixels that are
themselves nearly grey (``1 - 3 sigma_min < achromatic_tol``) even when a chromatic
``Lambda_max`` reached them from a neighbour: eq. 27 would call a grey pixel entirely
specular and paint it black (grey pavement next to a brown shoulder came out as
coloured speckles before this guard). The consequence, measured on
:mod:`simroad.noise` glare: a white sun glint on grey asphalt is *not* removed --
the dichromatic model cannot separate white light from a grey surface.
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad._validation import SimroadError, check_in_range, check_int_in_range
from simroad.filters._common import (
    channel_max,
    channel_min,
    channel_sum,
    check_filter_image,
    from_planes,
    to_planes,
)
from simroad.filters._threshold import otsu_threshold
from simroad.filters.guided import _guide_stats, _guided_planes

__all__ = ["dark_channel", "remove_glare", "remove_highlights", "specular_to_diffuse"]

_TINY = np.float32(1e-6)
_MAX_TINT = 2.0
_SCALE = 4  # the lobe is estimated on an image this many times smaller


def _check_patch(patch: int) -> int:
    patch = check_int_in_range("patch", patch, 1, 255)
    if patch % 2 == 0:
        raise SimroadError(f"patch: expected an odd window size, got {patch}. Use {patch + 1}.")
    return patch


def _dark_channel(planes: list[np.ndarray], patch: int) -> np.ndarray:
    dark = channel_min(planes)
    if patch == 1:
        return dark
    # cv2.erode's default border ignores outside pixels: a window clipped to the image.
    return cv2.erode(dark, np.ones((patch, patch), np.uint8))


def dark_channel(image: np.ndarray, patch: int = 7) -> np.ndarray:
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
    patch = _check_patch(patch)
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
    lam = np.asarray(lambda_max)
    if lam.shape != image.shape[:2] or lam.dtype.kind != "f":
        raise SimroadError(
            f"lambda_max: expected a float array of shape {image.shape[:2]}, got "
            f"{lam.dtype} {lam.shape}. Pass one chromaticity per pixel."
        )
    if not np.isfinite(lam).all() or lam.min() < 1.0 / 3.0 - 1e-6 or lam.max() > 1.0 + 1e-6:
        raise SimroadError("lambda_max: expected finite values in [1/3, 1] (a chromaticity maximum).")
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


def _crop_box(mask: np.ndarray, margin: int) -> tuple[slice, slice]:
    """Bounding box of ``mask`` grown by ``margin`` pixels, clipped to the image."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    h, w = mask.shape
    return (
        slice(max(0, rows[0] - margin), min(h, rows[-1] + 1 + margin)),
        slice(max(0, cols[0] - margin), min(w, cols[-1] + 1 + margin)),
    )


def _highlights_planes(planes, patch, radius, eps, iterations, achromatic_tol, subsample=1):
    """Core of :func:`remove_highlights` on float32 planes; returns (new planes, mask).

    ``Lambda_max`` is only estimated on the highlights' bounding box grown by the
    reach of the propagation (``2 r`` per pass plus ``r`` for the ceiling), which gives
    the same values inside the highlights as on the whole image.
    """
    dark = _dark_channel(planes, patch)
    mask = dark > otsu_threshold(dark)
    if not mask.any():
        return [p.copy() for p in planes], mask
    rs, cs = _crop_box(mask, radius * (2 * iterations + 1))
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
) -> tuple[np.ndarray, np.ndarray]:
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
    image : ndarray, same shape and dtype as the input
        Eq. 27 applied inside the highlight mask, the input elsewhere.
    highlight_mask : ndarray, bool, (H, W)
        Dark channel above its Otsu threshold. A constant dark channel has no
        threshold, so the mask is empty and the image is returned unchanged.
    """
    image = check_filter_image("image", image)
    patch = _check_patch(patch)
    radius = check_int_in_range("radius", radius, 1, 64)
    eps = check_in_range("eps", eps, 0.0, 1.0, low_inclusive=False)
    iterations = check_int_in_range("iterations", iterations, 0, 10)
    tol = check_in_range("achromatic_tol", achromatic_tol, 0.0, 1.0)
    subsample = check_int_in_range("subsample", subsample, 1, 4)
    out, mask = _highlights_planes(to_planes(image), patch, radius, eps, iterations, tol, subsample)
    return from_planes(out, image.dtype), mask


# ------------------------------------------------------------------ glare removal
# Eq. 27 cannot separate white light from a grey surface (see the module notes), and
# sun glare on asphalt is exactly that. The improved variant uses what eq. 23 says
# about the *specular* term instead: in linear radiance it is additive, smooth and has
# the sun's colour ``t``, so it lifts every channel -- and hence the darkest one -- by
# ``w_s G t_c``. A lobe on the road is a broad bright band narrower than the frame:
# a wide horizontal morphological opening of the (finely opened) darkest channel
# follows the diffuse floor under it, and the excess over that floor is the lobe.
# Where the sensor saturated, nothing of the surface is left: those pixels are
# inpainted from the corrected surroundings (OpenCV's Telea).


def _lobe_estimate(lin, fine, wide, min_excess, saturation, raw):
    """Glare lobe ``(excess, region, colour)`` on reduced-resolution linear planes, or None.

    ``excess`` is the darkest channel's lift over its wide opening (the diffuse floor),
    ``region`` the part of ``excess > min_excess`` connected to a saturated pixel of
    ``raw`` (the display-space planes), ``colour`` the lobe's colour per channel relative
    to the darkest channel (median ratio of the channels' own lifts where the lobe is
    strong and unsaturated).
    """
    k_fine = np.ones((fine, fine), np.uint8)
    k_wide = np.ones((1, wide), np.uint8)
    opened = [cv2.morphologyEx(p, cv2.MORPH_OPEN, k_fine) for p in lin]
    lifts = [o - cv2.morphologyEx(o, cv2.MORPH_OPEN, k_wide) for o in opened]
    darkest = int(np.argmin([float(x.sum()) for x in lifts]))
    excess = cv2.min(cv2.min(lifts[0], lifts[1]), lifts[2])
    region = excess > min_excess
    sat = channel_min(raw) >= saturation
    n, labels = cv2.connectedComponents(region.view(np.uint8), connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(labels[sat & region])] = True
    keep[0] = False
    if not keep.any():
        return None
    region = keep[labels]
    unsat = region & (channel_max(raw) < 0.95)
    base = lifts[darkest][unsat]
    if base.size < 8:
        return None
    strong = base > np.percentile(base, 70)
    colour = np.array([float(np.median(x[unsat][strong] / np.maximum(base[strong], 1e-6))) for x in lifts], np.float32)
    return excess, region, np.clip(colour, 1.0, _MAX_TINT)


def _glare_planes(planes, fine, wide, min_excess, saturation, core, gamma, scale=_SCALE):
    """Core of :func:`remove_glare` on float32 planes; returns (new planes, glare mask)."""
    h, w = planes[0].shape
    out = [p.copy() for p in planes]
    if not (channel_min(planes) >= saturation).any():  # no clipped pixel: no glare to remove
        return out, np.zeros((h, w), bool)
    sh, sw = max(1, h // scale), max(1, w // scale)
    small = [cv2.resize(p, (sw, sh), interpolation=cv2.INTER_AREA) for p in planes]
    lin_small = [cv2.pow(p, float(gamma)) for p in small]
    found = _lobe_estimate(lin_small, fine, max(3, (wide // scale) | 1), min_excess, saturation, small)
    if found is None:
        return out, np.zeros((h, w), bool)
    excess, region, colour = found
    excess = cv2.resize(np.where(region, excess, 0).astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
    mask = excess > 0
    rs, cs = _crop_box(mask, 0)
    excess, inside = excess[rs, cs], mask[rs, cs]
    for c, (o, p) in enumerate(zip(out, planes)):
        lin = cv2.pow(np.ascontiguousarray(p[rs, cs]), float(gamma))
        lin -= excess * colour[c]
        np.maximum(lin, 0.0, out=lin)
        np.copyto(o[rs, cs], cv2.pow(lin, 1.0 / float(gamma)), where=inside)
    # Saturated pixels keep nothing of the surface: fill them from their surroundings
    # (at quarter resolution: the fill is smooth anyway).
    qh, qw = max(1, h // 4), max(1, w // 4)
    clipped = cv2.resize(
        ((channel_min(small) >= core) & region).view(np.uint8), (qw, qh), interpolation=cv2.INTER_NEAREST
    )
    if clipped.any():
        clipped = cv2.dilate(clipped, np.ones((3, 3), np.uint8))
        reduced = cv2.merge([cv2.resize(o, (qw, qh), interpolation=cv2.INTER_AREA) for o in out])
        filled = cv2.inpaint(
            cv2.convertScaleAbs(np.clip(reduced, 0.0, 1.0), alpha=255.0), clipped, 2, cv2.INPAINT_TELEA
        )
        where = cv2.resize(clipped, (w, h), interpolation=cv2.INTER_NEAREST) > 0
        fill_full = cv2.resize(filled, (w, h), interpolation=cv2.INTER_LINEAR)
        for c, o in enumerate(out):
            np.copyto(o, fill_full[..., c].astype(np.float32) * np.float32(1 / 255), where=where)
        mask |= where
    return out, mask


def remove_glare(
    image: np.ndarray,
    *,
    fine: int = 3,
    wide: int = 481,
    min_excess: float = 0.01,
    saturation: float = 0.98,
    core: float = 0.8,
    gamma: float = 2.2,
) -> tuple[np.ndarray, np.ndarray]:
    """Remove a sun glare lobe by subtracting its additive, sun-coloured radiance.

    The improved light filter (the paper's eq. 27 cannot act on grey asphalt). Working
    at quarter resolution in linear radiance ``L = I**gamma``: each channel is opened
    with a ``fine`` square (removing lane paint and texture) and then with a ``wide``
    horizontal line; the lift of the opened channel over its wide opening is what a
    broad, bright band added on top of the diffuse floor -- the specular lobe of eq. 23
    -- looks like. The glare region is where the darkest channel's lift exceeds
    ``min_excess`` and is connected to a pixel whose dark channel reaches
    ``saturation``; there each channel loses ``lift * t_c``, with ``t`` the lobe's
    colour (median ratio of each channel's lift to the darkest one's where the lobe is
    strong and unsaturated; a low sun is warm). Pixels at or above ``core`` in every
    channel were clipped by the sensor and are inpainted from their corrected
    surroundings (``cv2.inpaint``, Telea).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    fine : int, optional
        Side of the small opening, in quarter-resolution pixels, odd, in [1, 31].
    wide : int, optional
        Length of the horizontal opening in full-resolution pixels (a lobe is
        narrower), in [3, 4095]. The default is longer than a 320-pixel row: the
        floor is then the row's minimum.
    min_excess : float, optional
        Smallest linear lift that counts as glare, in (0, 1).
    saturation : float, optional
        A region is glare only if its dark channel reaches this somewhere, in (0, 1].
    core : float, optional
        Pixels whose three channels all reach this are inpainted, in (0, 1].
    gamma : float, optional
        Display gamma of the image (linear radiance = ``I**gamma``), in [1, 3].

    Returns
    -------
    image : ndarray, same shape and dtype as the input
    glare_mask : ndarray, bool, (H, W)
        The corrected pixels.
    """
    image = check_filter_image("image", image)
    fine = check_int_in_range("fine", fine, 1, 31)
    if fine % 2 == 0:
        raise SimroadError(f"fine: expected an odd window size, got {fine}. Use {fine + 1}.")
    wide = check_int_in_range("wide", wide, 3, 4095)
    min_excess = check_in_range("min_excess", min_excess, 0.0, 1.0, low_inclusive=False, high_inclusive=False)
    saturation = check_in_range("saturation", saturation, 0.0, 1.0, low_inclusive=False)
    core = check_in_range("core", core, 0.0, 1.0, low_inclusive=False)
    gamma = check_in_range("gamma", gamma, 1.0, 3.0)
    out, mask = _glare_planes(to_planes(image), fine, wide, min_excess, saturation, core, gamma)
    return from_planes(out, image.dtype), mask
