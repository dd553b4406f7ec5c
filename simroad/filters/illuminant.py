"""Sunlight's colour cast, removed: white balance of the ground towards the training light.

The detector's colour features (hue and saturation, §III-A) are learnt under one light:
simroad's clear weather is a bright overcast day. Under a clear sky the road is lit by
the sun and by the blue sky; a camera without auto white balance (simroad's, like many
automotive ones) records the ground with another colour, and a grey road that was warm
under cloud turns blue: the shipped model then calls almost all of it non-road (town,
shadow weather, held-out worlds: FNR near 100 %). That is the "shadow" weather's
largest effect, before any shadow.

The cast is measured where the detector looks, on the ground in front of the car: the
mean linear colour of the bottom ``rows`` of the frame, as log-chromaticities
``(log B/R, log G/R)``. Clear-weather frames of the training worlds span a box of them
(the worlds' materials differ): that is the per-frame test for the weather. A frame
inside the box is returned as it is; a frame outside it is balanced (von Kries: one
gain per channel in linear light) to the training frames' mean chromaticity, the gains
normalised so the mean brightness of those rows is kept.

Measured on validation worlds 200-203 (all four scenarios, 48 frames per weather): a
balance of *every* frame to the training mean brought town shadow FNR from 100 % to
4 % but cost clear frames FNR + 0.4, FPR + 0.9 points; moving a cast frame only onto
the box's edge left town shadow FNR at 77 % (the classifier's road is the worlds'
typical colour, not the edge of their range). Balancing to the mean only outside the
box keeps both: clear frames unchanged, the cast removed.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

from simroad.core.radiometry import GAMMA
from simroad.core.validation import check_in_range
from simroad.errors import InvalidParameterError
from simroad.filters._common import FilterResult, Planes, absent_on_preview, check_filter_image, from_planes, to_planes
from simroad.filters._kernels import LEVELS, level_rows, row_runs

__all__ = ["CLEAR_CHROMATICITY", "CLEAR_MEAN_CHROMATICITY", "remove_colour_cast"]

#: ``((log B/R low, high), (log G/R low, high))`` of the ground's mean linear colour (the
#: bottom 40 % of the rows) in simroad's clear-weather frames of the training worlds 0-15
#: (all four scenarios, 3 frames each: B/R -0.51..-0.05, G/R -0.34..0.03), widened by
#: 0.05 on each side.
CLEAR_CHROMATICITY = ((-0.56, 0.0), (-0.39, 0.08))
#: ``(log B/R, log G/R)`` of the mean linear colour of those frames' ground rows.
CLEAR_MEAN_CHROMATICITY = (-0.25, -0.11)

_TINY = 1e-6
_SCALE = 4
_LIMIT = 5.0  # |log-ratio| accepted in options (a factor of ~150)


def _finite_pair(name: str, value: object) -> tuple[float, float]:
    try:
        a, b = value  # type: ignore[misc]
        pair = (float(a), float(b))  # type: ignore[has-type]
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name}: expected two numbers (log B/R, log G/R), got {value!r}.") from None
    if not all(math.isfinite(x) and abs(x) <= _LIMIT for x in pair):
        raise InvalidParameterError(f"{name}: expected finite log-ratios within +-{_LIMIT}, got {value!r}.")
    return pair


def _box(value: object) -> tuple[tuple[float, float], tuple[float, float]]:
    try:
        b, g = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"chromaticity: expected ((log B/R low, high), (log G/R low, high)), got {value!r}."
        ) from None
    box = (_finite_pair("chromaticity", b), _finite_pair("chromaticity", g))  # type: ignore[has-type]
    if any(lo > hi for lo, hi in box):
        raise InvalidParameterError(f"chromaticity: each (low, high) needs low <= high, got {value!r}.")
    return box


def _cast_gains(planes: Planes, rows: float, box: Any, target: tuple[float, float], gamma: float) -> np.ndarray | None:
    """Per-channel linear gains (3,) that balance a cast outside ``box`` to ``target``; None inside it."""
    h, w = planes[0].shape
    top = min(h - 1, int(h * (1.0 - rows)))
    size = (max(1, w // _SCALE), max(1, (h - top) // _SCALE))  # a mean: a quarter of the pixels will do
    mean = np.array([float(cv2.pow(cv2.resize(p[top:], size, interpolation=cv2.INTER_AREA), gamma).mean())
                     for p in planes])  # fmt: skip
    if mean.min() <= _TINY:
        return None
    chroma = np.log(mean[[2, 1]] / mean[0])  # (log B/R, log G/R)
    if all(lo <= c <= hi for c, (lo, hi) in zip(chroma, box)):
        return None
    gains = np.array([1.0, math.exp(target[1] - chroma[1]), math.exp(target[0] - chroma[0])])
    return gains * (mean.sum() / float((gains * mean).sum()))


def _colour_cast_planes(
    planes: Planes, *, rows: float, chromaticity: Any, target: Any, gamma: float, inplace: bool = False,
    preview: Planes | None = None,
) -> tuple[Planes, np.ndarray]:  # fmt: skip
    """Core of :func:`remove_colour_cast` on float32 planes (options already checked, as for
    every filter core); (new planes, mask of changed pixels). ``inplace``: the balanced
    values are written into the given planes (the caller owns them). ``preview``: as for
    :func:`~simroad.filters.haze._haze_planes` (a large frame whose preview lies in the box is
    returned as it is)."""
    if absent_on_preview(planes, preview, lambda p: _cast_gains(p, rows, chromaticity, target, gamma) is None):
        return planes, np.zeros(planes[0].shape, bool)  # no cast on the preview
    gains = _cast_gains(planes, rows, chromaticity, target, gamma)
    if gains is None:
        return planes, np.zeros(planes[0].shape, bool)  # inside the box: the planes themselves
    out = []
    for p, g in zip(planes, gains):
        o = p if inplace else np.empty_like(p)
        _balance(p, np.float32(g), gamma, o)
        out.append(o)
    return out, np.ones(planes[0].shape, bool)


def _balance(p: np.ndarray, gain: np.float32, gamma: float, out: np.ndarray) -> None:
    """``out = clip(p**gamma * gain, 0, 1)**(1 / gamma)`` (``cv2.pow``, float32; ``out`` may be ``p``).

    A row of 8-bit levels takes one of 256 values, computed once per call and looked up
    (``cv2.pow`` depends on the value alone); other rows are computed as written.
    """
    powers = cv2.pow(LEVELS, gamma).reshape(-1) * gain
    np.clip(powers, 0.0, 1.0, out=powers)
    table = cv2.pow(powers, 1.0 / gamma).reshape(-1)
    codes, rows = np.empty(p.shape, np.uint8), np.empty(p.shape[0], bool)
    level_rows(p, table, out, codes, rows)
    for a, b in row_runs(rows):
        lin: np.ndarray = cv2.pow(p[a:b], gamma)
        lin *= gain
        np.clip(lin, 0.0, 1.0, out=lin)
        cv2.pow(lin, 1.0 / gamma, dst=out[a:b])


def remove_colour_cast(
    image: np.ndarray,
    *,
    rows: float = 0.4,
    chromaticity: tuple = CLEAR_CHROMATICITY,
    target: tuple = CLEAR_MEAN_CHROMATICITY,
    gamma: float = GAMMA,
) -> FilterResult:
    """Undo a colour cast of the light beyond what clear weather shows (see the module notes).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image, the ground at the bottom.
    rows : float, optional
        Fraction of the frame's rows, from the bottom, whose mean colour is measured,
        in (0, 1].
    chromaticity : ((float, float), (float, float)), optional
        The box of ``(log B/R, log G/R)`` of that mean (linear light) left as it is;
        default :data:`CLEAR_CHROMATICITY`, measured on simroad's clear weather.
    target : (float, float), optional
        ``(log B/R, log G/R)`` a frame outside the box is balanced to; default
        :data:`CLEAR_MEAN_CHROMATICITY`.
    gamma : float, optional
        Display gamma of the image (linear radiance = ``I**gamma``), in [1, 3].

    Returns
    -------
    FilterResult
        ``image``: same shape and dtype, balanced (an unchanged copy inside the box).
        ``mask``: bool (H, W), every pixel when a cast was removed, else none.
    """
    image = check_filter_image("image", image)
    rows = check_in_range("rows", rows, 0.0, 1.0, low_inclusive=False)
    box = _box(chromaticity)
    aim = _finite_pair("target", target)
    gamma = check_in_range("gamma", gamma, 1.0, 3.0)
    out, mask = _colour_cast_planes(
        to_planes(image), rows=rows, chromaticity=box, target=aim, gamma=gamma, inplace=True
    )
    return FilterResult(from_planes(out, image.dtype), mask)
