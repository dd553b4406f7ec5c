"""The improved light filter: subtract a sun glare lobe's additive radiance (dichromatic model, eq. 23).

Eq. 27 cannot separate white light from a grey surface (see :mod:`simroad.filters.highlights`), and
sun glare on asphalt is exactly that. The improved variant uses what eq. 23 says
about the *specular* term instead: in linear radiance it is additive, smooth and has
the sun's colour ``t``, so it lifts every channel -- and hence the darkest one -- by
``w_s G t_c``. A lobe on the road is a broad bright band narrower than the frame:
a wide horizontal morphological opening of the (finely opened) darkest channel
follows the diffuse floor under it, and the excess over that floor is the lobe.
Where the sensor saturated, nothing of the surface is left: those pixels are
inpainted from the corrected surroundings (OpenCV's Telea).
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad._validation import check_in_range, check_int_in_range
from simroad.filters._common import (
    FilterResult,
    Planes,
    channel_max,
    channel_min,
    check_filter_image,
    check_odd_size,
    crop_box,
    from_planes,
    to_planes,
)

__all__ = ["remove_glare"]

_MAX_TINT = 2.0
_SCALE = 4  # the lobe is estimated on an image this many times smaller


def _lobe_estimate(
    lin: Planes, fine: int, wide: int, min_excess: float, saturation: float, raw: Planes
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
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


def _glare_planes(
    planes: Planes,
    *,
    fine: int,
    wide: int,
    min_excess: float,
    saturation: float,
    core: float,
    gamma: float,
    scale: int = _SCALE,
) -> tuple[Planes, np.ndarray]:
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
    rs, cs = crop_box(mask, 0)
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
) -> FilterResult:
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
    FilterResult
        ``image``: same shape and dtype as the input, the lobe removed. ``mask``:
        bool (H, W), the corrected pixels (the glare region and the inpainted ones).
    """
    image = check_filter_image("image", image)
    fine = check_odd_size("fine", fine, 1, 31)
    wide = check_int_in_range("wide", wide, 3, 4095)
    min_excess = check_in_range("min_excess", min_excess, 0.0, 1.0, low_inclusive=False, high_inclusive=False)
    saturation = check_in_range("saturation", saturation, 0.0, 1.0, low_inclusive=False)
    core = check_in_range("core", core, 0.0, 1.0, low_inclusive=False)
    gamma = check_in_range("gamma", gamma, 1.0, 3.0)
    out, mask = _glare_planes(
        to_planes(image), fine=fine, wide=wide, min_excess=min_excess, saturation=saturation, core=core, gamma=gamma
    )
    return FilterResult(from_planes(out, image.dtype), mask)
