"""Cast shadows relit by physics: one sky/sun ratio per frame, divided out in linear light.

Physics
-------
A ground texel of albedo ρ in the sun has linear radiance ``ρ·(E_sun·cos θ + E_sky)``;
in a cast shadow only the sky lights it: ``ρ·E_sky``. The ratio
``k_c = E_sky / (E_sun·cos θ + E_sky)`` per channel (R, G, B) depends on the light
alone, so it is *one* vector for every shadow on the ground of a frame, whatever the
material; the sky is bluer than the sun, so ``k_R < k_G < k_B``. In log linear light a
shadow therefore adds the same vector ``d = log k`` to every pixel it covers (a
penumbra, a fraction ``α`` of it: ``log(1 − α (1 − k))``). The camera's response (a
highlight shoulder and the display encoding, gamma 2.2, :mod:`simroad.camera.sensor`) is undone
first: ratios are only constant in linear light. Vignetting and the white balance are
per-pixel or per-channel gains and cancel in the ratios.

Steps (on the bottom ``rows`` of the frame, the ground, at half resolution)
-----------------------------------------------------------------------------
1. **Is the sun out?** Cast shadows need direct sun, and direct sun a clear (blue)
   sky: the median ``log B/R`` (linear) of the top ``sky_rows`` of the frame must exceed
   ``min_sky_blue``. A frame under an overcast, rainy, snowy or foggy sky is returned
   as it is, bit for bit (clear weather's dark repair patches look like shadows).
2. **Pairs across shadow edges.** Pixel pairs 8 px apart (full resolution) whose log
   difference darkens every channel, red most and blue least (blue by at least a
   quarter of red's darkening less), red by at least ``min_drop``; fewer than
   ``min_pairs`` such pairs: no shadow, the frame is returned as it is. The median of
   the strongest quarter of the pairs is the first estimate of ``d``.
3. **Shadows and the ratio, alternately.** Each pixel's lit reference is the mean of
   the lit pixels in a ``window`` box around it (a 3x larger box where the first holds
   too few, else the frame's mean). The lit pixels are at first those within 0.8 of a
   shadow step of the brightest, along ``d``, in the larger box (so a shadow wider than
   the box is not its own reference), then every pixel outside the shadows and their
   penumbra band. ``α`` is the projection of (pixel − reference) on ``d``; a pixel is
   shadow where ``α > 0.5`` *and* its chromaticity moved towards blue as ``d``'s does
   (at least 0.35 of it), which rejects darker grey materials next to a bright one.
   ``d`` is re-estimated as the median (pixel − reference) over the eroded shadow
   cores, until it moves less than 0.01 (at most 6 rounds).
4. **Relight.** Within the shadows grown by their penumbra band, linear radiance is
   divided by ``1 − α (1 − k)`` (``α`` clipped to [0, 1]) and re-encoded; every other
   pixel keeps its value exactly.

Measured on validation worlds 200-203 (48 frames per cell, all four scenarios, after
:func:`~simroad.filters.illuminant.remove_colour_cast`), detector FNR / FPR with the
improved shadow filter, its second step the paper's ``remove_shadows`` -> this one:
shadow 0.4 6.7 / 1.1 -> 6.3 / 1.2 %, shadow 0.8 15.3 / 1.0 -> 11.3 / 1.0 %. Clear,
rain, snow and fog frames come back bit-identical (the sky test); 1 of 48 glare
frames at 0.4 and at 0.8 is touched, the cells' FNR/FPR unchanged. Without the sky
test 14 of 48 clear frames held enough shadow-like pairs (repair patches, window
bands of buildings). Cost at 320x180 (CPU time on the shared machine, ``make bench``):
about 0.1 ms on frames without shadows (the sky test), about 2 ms on shadow frames (six
frames at severity 0.7: median 3.6 ms before the loops below were compiled, December
2026), most of it the rounds of step 3. Their box filters, projections, medians and
per-pixel steps, the first guess of the lit pixels, the first estimate of ``d`` and the
relighting are compiled (:mod:`simroad.filters._relight_kernels`), bit for bit the
numpy/OpenCV computation they replace; the projections sum their three products in the
order the BLAS numpy ships with sums them (``np.tensordot``; another BLAS may round an
``α`` differently in its last bit).
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from simroad.core.validation import check_in_range, check_int_in_range
from simroad.filters._common import (
    FilterResult,
    Planes,
    absent_on_preview,
    camera_to_linear,
    check_filter_image,
    from_planes,
    linear_to_camera,
    to_planes,
)
from simroad.filters._kernels import (
    linear_halves,
    median_at_most,
    quantize_take,
)
from simroad.filters._lit_boxes import lit_diff, minus_at
from simroad.filters._relight_kernels import (
    alpha_chroma,
    clip_inside,
    edge_pairs,
    first_lit,
    first_lit_work,
    lit_outside,
    next_direction,
    project,
    put_at,
    relit_linear,
    shadow_update,
    sky_ratios,
    strong_median,
)
from simroad.filters._workspace import scratch

__all__ = ["relight_shadows"]

_LEVELS = 4096
_SAT = 0.97  # linear level treated as clipped
_DARK = 2e-3  # linear level below which the noise rules
_SHIFT = 4  # pair offset at half resolution (8 px at full)
_GROW = 4  # penumbra band at half resolution (8 px at full)
_CORE = 2
_ROUNDS = 6
_MIN_ALPHA, _MIN_CHROMA = 0.5, 0.35
_FIRST_LIT = 0.8  # first guess of the lit: within this many shadow steps of the brightest
_BLUER = 0.25  # a shadow edge keeps at least this much more of its blue than of its red (log)


@functools.lru_cache(maxsize=8)
def _linear_table(shoulder: float) -> np.ndarray:
    """Encoded level (``_LEVELS`` steps of [0, 1]) -> the camera's linear signal (read-only)."""
    table = camera_to_linear(np.linspace(0.0, 1.0, _LEVELS, dtype=np.float32), shoulder)
    table.setflags(write=False)
    return table


def _linearise(p: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Float32 plane in [0, 1] -> linear signal by ``table`` (nearest of its levels):
    ``table[clip(rint(p * (_LEVELS - 1)), 0, _LEVELS - 1)]``, compiled."""
    out = np.empty(p.shape, np.float32)
    quantize_take(p, table, out)
    return out


def _linear_small(p: np.ndarray, table: np.ndarray, ws: int) -> np.ndarray:
    """:func:`_linearise` of ``p``, then reduced to half size (``cv2.resize``, area): in one
    compiled pass where the halving is exact (even sides), else as written."""
    h, w = p.shape
    if w == 2 * ws and h % 2 == 0:
        out = np.empty((h // 2, ws), np.float32)
        linear_halves(p, table, out)
        return out
    return cv2.resize(_linearise(p, table), (ws, h // 2), interpolation=cv2.INTER_AREA)


def _sky_not_blue(planes: Planes, table: np.ndarray, sky_rows: float, min_sky_blue: float) -> bool:
    """Whether the median linear ``log B/R`` of the unclipped pixels of the top rows is at
    most ``min_sky_blue`` (or fewer than 30 pixels are unclipped).

    Unclipped: every channel under ``_SAT``, red above 0.03, blue above ``_DARK``; the
    pixels are linearised and tested in one compiled pass, and the median is compared
    with the threshold by counting (:func:`~simroad.filters._kernels.median_at_most`).
    """
    top = max(1, int(round(sky_rows * planes[0].shape[0])))
    ratios = np.empty(top * planes[0].shape[1], np.float32)
    n = sky_ratios(planes[0][:top], planes[1][:top], planes[2][:top], table, np.float32(_SAT), np.float32(0.03),
                   np.float32(_DARK), ratios)  # fmt: skip
    return n < 30 or median_at_most(np.log(ratios[:n]), min_sky_blue)


def _edge_pairs(logs: np.ndarray, valid: np.ndarray, min_drop: float) -> np.ndarray:
    """Log differences (dark - lit), (N, 3), of the shadow-like pairs ``_SHIFT`` apart (compiled)."""
    return edge_pairs(logs, valid, _SHIFT, np.float32(min_drop), np.float32(_BLUER))


def _lit_diff(logs: np.ndarray, lit: np.ndarray, window: int, *, eager: bool = True) -> np.ndarray:
    """``logs`` minus the mean log colour (3, h, w) of the ``lit`` (float 0/1) pixels around
    each pixel: a ``window`` box, a 3x larger one where it holds too few, else the frame's mean.

    Both boxes and the difference in one compiled pass (:func:`~simroad.filters._lit_boxes.lit_diff`:
    ``cv2.blur`` of ``lit`` and ``logs * lit``, bit for bit, the ratio where the weight
    exceeds 0.15), in ``lit``'s dtype; the larger box only where the smaller holds too few,
    the frame's mean only when some pixel needs it. ``eager``: both boxes' row sums in one
    pass (where the first box will hold too few in most columns, as around the first guess
    of the lit pixels), else the larger box's only for the columns that need it.
    """
    kind = lit.dtype.type
    diff = scratch("relight diff", logs.shape, lit.dtype)  # valid until the next call: the caller keeps none
    rest = scratch("relight rest", lit.shape, np.uint8)
    sums = scratch("relight row sums", (2, lit.shape[0], 4, lit.shape[1]), np.float64)
    if lit_diff(logs, lit, (window, 3 * window), kind(0.15), kind(1e-6), diff, rest, sums, eager):
        weighted = np.multiply(logs, lit, out=scratch("relight weighted logs", diff.shape, diff.dtype))
        frame = weighted.sum(axis=(1, 2)) / max(float(lit.sum()), 1.0)
        minus_at(logs, frame, rest, 2, diff)
    return diff


def _alpha_chroma(diff: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's shadow fraction ``α``, the coordinate of ``diff`` (3, h, w) along ``d``, and
    its chromaticity's move along ``d``'s, blurred 3x3 and 5x5 (float32 (h, w) each).

    The projections ``np.tensordot(d, x, 1).astype(np.float32) / np.float32(d @ d)`` of ``diff``
    on ``d`` and of ``diff - diff.mean(axis=0)`` on ``d - d.mean()`` in one compiled pass
    (:func:`~simroad.filters._relight_kernels.alpha_chroma`: the three products summed in
    the order OpenBLAS's gemv sums them, bit for bit here).
    """
    dc = d - (d[0] + d[1] + d[2]) / 3  # d - d.mean(): numpy sums three values left to right
    alpha = scratch("relight alpha", diff.shape[1:], np.float32)
    chroma = scratch("relight chroma", diff.shape[1:], np.float32)
    alpha_chroma(diff, d, np.float32(d @ d), dc, np.float32(dc @ dc), alpha, chroma)
    blurred = scratch("relight blurred chroma", chroma.shape, np.float32)  # read before the next round
    return cv2.blur(alpha, (3, 3)), cv2.blur(chroma, (5, 5), dst=blurred)


def _coverage(
    logs: np.ndarray, valid: np.ndarray, d: np.ndarray, window: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps 3 of the module notes: (alpha (h, w), shadow mask (h, w), d (3,))."""
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _GROW + 1, 2 * _GROW + 1))
    core_disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _CORE + 1, 2 * _CORE + 1))
    lit_ok = valid.astype(np.float32)
    # First guess of the lit pixels: within half a shadow step of the brightest (along
    # d) of a wide box around them, so a shadow wider than the box is not its own reference.
    bright = scratch("relight bright", valid.shape, np.float32)
    project(logs, d, -np.float32(d @ d), bright)  # (np.tensordot(d, logs, 1) / -float(d @ d)).astype(np.float32)
    lit = np.empty(valid.shape, np.float32)
    work = scratch("relight first lit", (first_lit_work(valid.shape[0], valid.shape[1], 3 * window),), np.float32)
    first_lit(bright, lit_ok, 3 * window, np.float32(_FIRST_LIT), lit, work)
    shadow = np.empty(valid.shape, np.uint8)
    for round_ in range(_ROUNDS):
        diff = _lit_diff(logs, lit, window, eager=round_ == 0)  # the first guess leaves wide gaps
        alpha, chroma = _alpha_chroma(diff, d)
        shadow_update(alpha, chroma, valid, np.float32(_MIN_ALPHA), np.float32(_MIN_CHROMA), shadow)
        lit = scratch("relight lit", valid.shape, np.float64)  # the last round's is read already
        lit_outside(lit_ok, cv2.dilate(shadow, disc), lit)  # lit_ok * (1.0 - dilated shadow)
        new = np.empty(3, diff.dtype)  # the median (pixel - reference) over the eroded shadow cores
        cores, moved = next_direction(diff, cv2.erode(shadow, core_disc), d, 20, diff.dtype.type(-1e-3), new)
        if cores <= 20:
            break
        d = new
        if moved < 0.01:
            break
    return alpha, shadow, d


def _relight_band(
    planes: Planes, full: np.ndarray, top: int, k: np.ndarray, table: np.ndarray, shoulder: float, inplace: bool
) -> tuple[Planes, np.ndarray] | None:
    """Step 4 of the module notes on the rows from ``top`` that ``full`` (``α`` at full resolution,
    clipped, 0 outside the grown shadows) covers: where ``α > 0.02``, linear radiance divided
    by ``1 − α (1 − k)`` (compiled, :func:`~simroad.filters._relight_kernels.relit_linear`) and
    re-encoded (:func:`~simroad.filters._common.linear_to_camera`, the three channels in one
    call); (new planes, relit mask), or None when no pixel is."""
    h, w = planes[0].shape
    band = slice(top, top + full.shape[0])
    where = scratch("relight where", (full.size,), np.int64)
    lin = scratch("relight linear", (3, full.size), np.float32)
    mask = np.zeros((h, w), bool)
    n = relit_linear(full, np.float32(0.02), planes[0][band], planes[1][band], planes[2][band], table, k, where, lin,
                     mask[band])  # fmt: skip
    if not n:
        return None
    out = list(planes) if inplace else [p.copy() for p in planes]
    put_at(where[:n], linear_to_camera(lin[:, :n], shoulder), out[0][band], out[1][band], out[2][band])
    return out, mask


def _relight_planes(
    planes: Planes, *, shoulder: float, rows: float, sky_rows: float, min_sky_blue: float,
    min_drop: float, min_pairs: int, window: int, inplace: bool = False, preview: Planes | None = None,
) -> tuple[Planes, np.ndarray]:  # fmt: skip
    """Core of :func:`relight_shadows` on float32 planes; (new planes, relit mask). ``inplace``:
    the relit pixels are written into the given planes (the caller owns them). ``preview``: as
    for :func:`~simroad.filters.haze._haze_planes` (step 1, the sky test, first on the preview)."""
    h, w = planes[0].shape
    unchanged = (planes, np.zeros((h, w), bool))  # no shadow to relight: the planes themselves
    table = _linear_table(shoulder)
    if absent_on_preview(planes, preview, lambda p: _sky_not_blue(p, table, sky_rows, min_sky_blue)):
        return unchanged  # no blue sky on the preview
    top = min(h - 2, int(h * (1.0 - rows)))
    hs, ws = (h - top) // 2, w // 2
    if hs < 2 * _SHIFT or ws < 2 * _SHIFT or _sky_not_blue(planes, table, sky_rows, min_sky_blue):
        return unchanged
    small = [_linear_small(p[top : top + 2 * hs], table, ws) for p in planes]
    valid = (cv2.max(cv2.max(small[0], small[1]), small[2]) < _SAT) & (
        cv2.min(cv2.min(small[0], small[1]), small[2]) > _DARK
    )
    logs = np.empty((3, *small[0].shape), np.float32)
    for p, log in zip(small, logs):  # np.log(np.maximum(cv2.blur(p, (3, 3)), _DARK)), no temporaries
        box = cv2.blur(p, (3, 3))
        np.log(np.maximum(box, np.float32(_DARK), out=box), out=log)
    pairs = _edge_pairs(logs, valid, min_drop)
    if len(pairs) < min_pairs:
        return unchanged
    d0 = strong_median(pairs, 75.0)  # the median of the strongest quarter of the pairs (by red)
    alpha, shadow, d = _coverage(logs, valid, d0, window)
    region = cv2.dilate(shadow, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _GROW + 1, 2 * _GROW + 1)))
    inside = np.empty(alpha.shape, np.float32)
    clip_inside(alpha, region, inside)  # np.where(region > 0, np.clip(alpha, 0.0, 1.0), 0.0)
    full = cv2.resize(inside, (w, 2 * hs), interpolation=cv2.INTER_LINEAR)
    relit = _relight_band(planes, full, top, np.exp(d).astype(np.float32), table, shoulder, inplace)
    return unchanged if relit is None else relit


def relight_shadows(
    image: np.ndarray,
    *,
    shoulder: float = 1.0,
    rows: float = 0.6,
    sky_rows: float = 0.25,
    min_sky_blue: float = 0.25,
    min_drop: float = 0.5,
    min_pairs: int = 40,
    window: int = 31,
) -> FilterResult:
    """Find the cast shadows on the ground and relight them by the frame's one sky/sun ratio.

    See the module notes for the physics and the steps.

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image from a camera with simroad's response (gamma 2.2 with a shoulder).
    shoulder : float, optional
        Strength ``k`` of the camera response's shoulder ``(1 + k) y / (1 + k y)``
        (:class:`simroad.camera.sensor_params.SensorParams` ``tone_shoulder``), in [0, 20].
    rows : float, optional
        Fraction of the rows, from the bottom, searched for shadows (the ground), in (0, 1].
    sky_rows : float, optional
        Fraction of the rows, from the top, whose colour tells whether the sky is
        clear, in (0, 1].
    min_sky_blue : float, optional
        Smallest median linear ``log(B/R)`` of those rows for a clear sky (the sun
        out), in [-5, 5]; simroad's overcast skies stay under 0.15.
    min_drop : float, optional
        Smallest red log-darkening of an edge pair that may be a shadow edge, in (0, 5].
    min_pairs : int, optional
        Fewest shadow-like edge pairs for the frame to hold shadows, >= 1.
    window : int, optional
        Side of the box, in half-resolution pixels, over which a shadow's lit
        reference is averaged, in [3, 255].

    Returns
    -------
    FilterResult
        ``image``: same shape and dtype; shadow pixels divided by ``1 − α (1 − k)`` in
        linear light, every other pixel unchanged (the whole image when no shadow is
        found). ``mask``: bool (H, W), the pixels relit.
    """
    image = check_filter_image("image", image)
    out, mask = _relight_planes(
        to_planes(image),
        shoulder=check_in_range("shoulder", shoulder, 0.0, 20.0),
        rows=check_in_range("rows", rows, 0.0, 1.0, low_inclusive=False),
        sky_rows=check_in_range("sky_rows", sky_rows, 0.0, 1.0, low_inclusive=False),
        min_sky_blue=check_in_range("min_sky_blue", min_sky_blue, -5.0, 5.0),
        min_drop=check_in_range("min_drop", min_drop, 0.0, 5.0, low_inclusive=False),
        min_pairs=check_int_in_range("min_pairs", min_pairs, 1, 1 << 30),
        window=check_int_in_range("window", window, 3, 255),
        inplace=True,
    )
    return FilterResult(from_planes(out, image.dtype), mask)
