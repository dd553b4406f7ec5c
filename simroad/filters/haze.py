"""Haze of falling rain and snow, removed row by row (Koschmieder's law).

Falling snow and rain do not only blend particles into the image (eq. 19): the
particles too small to resolve scatter light along every line of sight, and a
surface at distance ``d`` is seen as ``I = J t + A (1 - t)`` with transmission
``t = exp(-beta d)`` and airlight ``A`` (Koschmieder's law, in linear radiance). At
snow severity 0.5 (visibility ~450 m) a road 100 m ahead keeps ``t ~ 0.4`` of its own
radiance: the far road turns into the pale grey of a shoulder, and the colour
classifier drops it -- most of the detector's FNR in light snow is this veil, not the
flakes.

For a camera without roll over flat ground, distance grows with image height up to
the horizon, so ``t`` is a function of the row. This filter estimates it from the image
itself:

* ``A`` -- the median colour of the top eighth of the rows: the sky, which is the
  airlight itself (a surface at infinite distance has ``t = 0``). A *blue* sky (linear
  saturation ``1 - min/mean`` above 0.15) means clear air: the frame is returned as it
  is. Rain and snow skies are grey (saturation < 0.04 in simroad's weather), clear skies
  blue (> 0.35); without that test, the rise of the far rows' floor where the road
  narrows between pale roadsides was read as haze, and the filter darkened them;
* the **row floor** ``f(r)`` -- a low percentile of the darkest channel of row ``r``:
  the darkest surface of the row (asphalt), lifted by the veil. It is made
  non-decreasing upwards (haze only grows with distance);
* ``J_0``, the floor of the nearest rows (bottom eighth, taken as clear, ``t ~ 1``), and
  ``t(r) = 1 - max(0, f(r) - J_0 - tolerance) / (A_min - J_0)`` -- the fraction of the
  unveiled contrast left -- clipped to ``[t_min, 1]``;
* ``J = (I - A (1 - t)) / t`` per channel, in linear radiance ``I**gamma``.

The statistics are taken on every row at a quarter of the width. ``t_min`` caps the
gain ``1 / t`` near the horizon, where the floor is also lifted by the roadside
blending into the road.

In snow the veil, not the flakes, is most of the detector's FNR; in rain the step
costs some FPR, since the wet road's reflection of the sky also brightens the far rows
and is removed as if it were haze (``simroad filter-effect`` measures both; README).
:func:`remove_haze` is the first step of the rain/snow filter's improved variant
(:func:`simroad.filters.apply_filters`), with ``tolerance=0.045``: simroad's clear
weather includes bright overcast days whose far rows rise a little by the roadside's
blending and aerial perspective, which a smaller tolerance reads as haze.

**The near-veil gate**: a filter does nothing where its weather is absent. The step
acts only where the monotone (isotonic) fit of the row floor rises above the tolerance
on the lower half of the rows (:func:`_near_veil`). A veil grows with distance from the
bottom row up; a pale thing across a few near rows (a white car's flank, the road
narrowing between pale verges) does not lift a fit that must average it with every row
above, so such clean frames are returned exactly as they are.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from simroad.core.radiometry import GAMMA
from simroad.core.validation import check_in_range
from simroad.filters._common import (
    FilterResult,
    Planes,
    absent_on_preview,
    check_filter_image,
    from_planes,
    pow_sparing_zeros,
    to_planes,
)
from simroad.filters._kernels import (
    LEVELS,
    MONOTONE_FROM,
    MONOTONE_POWERS,
    apply_shared_tables,
    area4_floor,
    level_codes,
    median,
)
from simroad.filters._plane_kernels import isotonic_increasing

__all__ = ["remove_haze"]

_SCALE = 4  # statistics at a quarter of the width
#: Saturation ``1 - min/mean`` of the airlight (linear) above which the sky is blue: clear air.
#: A camera's white balance errs by about 15 mired (:class:`~simroad.camera.SensorParams`),
#: which tints a grey rain or snow sky: 0.12-0.36 measured on rain and snow frames of
#: worlds 110-115, against 0.03-0.87 for clear skies (whose grey, overcast ones the
#: veil tests below turn away).
_MAX_SKY_SATURATION = 0.4


def _row_floor(planes: Planes, sw: int, kth: int, gamma: float) -> np.ndarray:
    """Each row's ``kth`` smallest linear value of the darkest channel at width ``sw``, (h,) float32.

    The planes reduced (area), raised to ``gamma``, their darkest channel and each row's
    order statistic -- computed, where that is the same bit for bit (an integer
    reduction, ``cv2.pow`` monotone: :mod:`simroad.filters._kernels`), as the power of
    each row's order statistic in one compiled pass: ``h`` powers instead of three planes.
    """
    h, w = planes[0].shape
    floor = np.empty(h, np.float32)
    if (
        w == 4 * sw
        and gamma in MONOTONE_POWERS
        and not area4_floor(planes[0], planes[1], planes[2], kth, floor, MONOTONE_FROM)
    ):
        return cv2.pow(floor, gamma).reshape(-1)
    lin = [cv2.pow(cv2.resize(p, (sw, h), interpolation=cv2.INTER_AREA), gamma) for p in planes]
    return np.partition(cv2.min(cv2.min(lin[0], lin[1]), lin[2]), kth, axis=1)[:, kth]


@functools.lru_cache(maxsize=8)
def _level_powers(gamma: float) -> np.ndarray:
    """``cv2.pow`` of the 256 float32 8-bit levels (read-only)."""
    out = cv2.pow(LEVELS, gamma).reshape(-1)
    out.setflags(write=False)
    return out


def _dehaze_rows(p: np.ndarray, out: np.ndarray, n: int, gain: np.ndarray, lift: np.ndarray, gamma: float) -> None:
    """Rows ``[:n]`` of ``out``: ``clip(p**gamma gain + lift, 0, 1)**(1 / gamma)``, one gain and lift per row (n, 1).

    On a plane of 8-bit levels (the detector's frames) each row takes at most 256
    values: they are computed once per run of rows with the same gain and lift (``t``
    is constant over runs of rows where the floor is flat or ``t_min`` caps it; ``cv2.pow``
    depends on the value alone) and looked up. Any other plane is computed as written.
    """
    codes = np.empty((n, p.shape[1]), np.uint8)
    if level_codes(p[:n], codes):
        # Start of each run of equal (gain, lift) rows, and each row's run.
        new = np.ones(n, bool)
        new[1:] = (gain[1:, 0] != gain[:-1, 0]) | (lift[1:, 0] != lift[:-1, 0])
        run = np.cumsum(new) - 1
        tables = _level_powers(gamma).reshape(1, -1) * gain[new]
        tables += lift[new]
        np.clip(tables, 0.0, 1.0, out=tables)
        apply_shared_tables(codes, pow_sparing_zeros(tables, 1.0 / gamma), run, out[:n])
        return
    lin = cv2.pow(p[:n], gamma)
    lin *= gain
    lin += lift
    np.clip(lin, 0.0, 1.0, out=lin)
    cv2.pow(lin, 1.0 / gamma, dst=out[:n])


def _near_veil(floor: np.ndarray, clear_floor: float) -> bool:
    """Whether the veil reaches the near ground: the least-squares fit of the row floor
    that never falls upwards (isotonic regression,
    :func:`~simroad.filters._plane_kernels.isotonic_increasing`) rises above
    ``clear_floor`` on the lower half of the rows.

    A veil ``1 - exp(-beta d)`` grows with distance, so the floor of a veiled frame
    climbs row by row from the bottom; a few rows lifted by one bright thing (a white
    car's flank, the road narrowing between pale verges) barely move a monotone fit,
    which must average them with every row above. Of the lower half's rows the fit is
    highest at the top one, the middle row of the frame: the test reads that row.
    """
    fit = isotonic_increasing(np.ascontiguousarray(floor[::-1], dtype=np.float64))[::-1]
    return bool(fit[floor.shape[0] // 2] > clear_floor)


def _transmission(
    planes: Planes,
    percentile: float,
    t_min: float,
    tolerance: float,
    gamma: float,
    max_sky_saturation: float = _MAX_SKY_SATURATION,
    scale: int = _SCALE,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-row transmission ``t`` (H,) float32 and airlight ``A`` (3,) in linear radiance, or None."""
    h, w = planes[0].shape
    sh, sw = h, max(1, w // scale)  # every row kept: t changes fast near the horizon
    top = max(1, h // 8)  # the sky at the top of the frame is the airlight
    sky = [cv2.pow(cv2.resize(p[:top], (sw, top), interpolation=cv2.INTER_AREA), gamma) for p in planes]
    airlight = np.array([float(median(x)) for x in sky], np.float32)
    a_min = float(airlight.min())
    if 1.0 - a_min / max(float(airlight.mean()), 1e-6) > max_sky_saturation:
        return None  # a blue sky: clear air, no veil worth removing (and the far rows' rise is the roadside)
    kth = min(sw - 1, int(round(percentile / 100.0 * (sw - 1))))
    floor = _row_floor(planes, sw, kth, gamma)  # sh = h
    j0 = float(median(floor[sh - max(1, sh // 8) :]))
    if a_min - j0 < 1e-3:  # no contrast between the near ground and the airlight
        return None
    if not _near_veil(floor, j0 + tolerance):
        return None  # no veil over the near ground: the far rows' rise is the scene, not the air
    floor = np.maximum.accumulate(floor[::-1])[::-1]  # non-decreasing upwards
    lift = np.maximum(floor - j0 - tolerance, 0.0)  # the veil over the near ground, beyond the tolerance
    t_small = np.clip(1.0 - lift / (a_min - j0), t_min, 1.0)
    if t_small.min() >= 1.0:
        return None
    return t_small.astype(np.float32), airlight


def _haze_planes(
    planes: Planes, *, percentile: float, t_min: float, tolerance: float, gamma: float, inplace: bool = False,
    preview: Planes | None = None,
) -> tuple[Planes, np.ndarray]:  # fmt: skip
    """Core of :func:`remove_haze` on float32 planes in [0, 1]; (new planes, mask of the corrected rows).
    ``inplace``: the corrected rows are written into the given planes (the caller owns them).
    ``preview``: :func:`~simroad.filters._common.gate_preview` of the planes when the caller has
    it (a frame larger than ``GATE_SIZE`` without veil on its preview is returned as it is)."""
    mask = np.zeros(planes[0].shape, bool)
    if absent_on_preview(
        planes, preview, lambda p: _transmission(p, percentile, t_min, tolerance, float(gamma)) is None
    ):
        return planes, mask  # no veil on the preview
    found = _transmission(planes, percentile, t_min, tolerance, float(gamma))
    if found is None:
        return planes, mask  # no veil: the planes themselves
    t, airlight = found
    # t never grows upwards (the floor is made non-decreasing upwards), so the veiled
    # rows are the top ``n`` rows of the frame.
    n = int(np.count_nonzero(t < 1.0))
    mask[:n] = True
    gain = 1.0 / t[:n, None]
    lift = 1.0 - gain  # J = I / t - A (1 - t) / t = I gain + A lift
    out = list(planes) if inplace else [np.empty_like(p) for p in planes]
    for o, p, a in zip(out, planes, airlight):
        if not inplace:
            o[n:] = p[n:]
        _dehaze_rows(p, o, n, gain, a * lift, float(gamma))
    return out, mask


def remove_haze(
    image: np.ndarray,
    *,
    percentile: float = 2.0,
    t_min: float = 0.5,
    tolerance: float = 0.01,
    gamma: float = GAMMA,
) -> FilterResult:
    """Remove the veil of rain or snow haze, row by row (see the module notes).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image from a camera without roll over flat ground, the sky at the top.
    percentile : float, optional
        Percentile of each row's darkest channel taken as the row floor, in [0, 50].
    t_min : float, optional
        Smallest transmission restored, in (0, 1]; caps the gain ``1 / t``.
    tolerance : float, optional
        Rise of the floor over the near ground (linear radiance) still taken as clear
        air, in [0, 1].
    gamma : float, optional
        Display gamma of the image (linear radiance = ``I**gamma``), in [1, 3].

    Returns
    -------
    FilterResult
        ``image``: the haze-free image, same shape and dtype as the input; rows
        without haze are returned unchanged. ``mask``: bool (H, W), True on the rows
        that were corrected (``t < 1``; always a block of top rows).
    """
    image = check_filter_image("image", image)
    percentile = check_in_range("percentile", percentile, 0.0, 50.0)
    t_min = check_in_range("t_min", t_min, 0.0, 1.0, low_inclusive=False)
    tolerance = check_in_range("tolerance", tolerance, 0.0, 1.0)
    gamma = check_in_range("gamma", gamma, 1.0, 3.0)
    out, mask = _haze_planes(
        to_planes(image), percentile=percentile, t_min=t_min, tolerance=tolerance, gamma=gamma, inplace=True
    )
    return FilterResult(from_planes(out, image.dtype), mask)
