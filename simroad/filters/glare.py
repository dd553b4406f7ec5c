"""The improved light filter: subtract a sun glare lobe's additive radiance (dichromatic model, eq. 23), re-expose.

Eq. 27 cannot separate white light from a grey surface (see :mod:`simroad.filters.highlights`), and
sun glare on asphalt is exactly that. The improved variant uses what eq. 23 says
about the *specular* term instead: in linear radiance it is additive, smooth and has
the sun's colour ``t`` (warm at a low sun), so it lifts channel ``c`` by ``B t_c``.

What the camera then does matters as much as the lobe: its auto-exposure meters the
lower part of the frame, so a bright lobe there lowers the exposure and the road
*beside* the lobe turns darker than the detector has ever seen it. The filter
therefore works in the camera's linear signal (display gamma 2.2 decoded, the response curve's
shoulder undone), removes the lobe, and re-exposes the frame as the camera would
have metered it without the lobe.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from simroad.core.radiometry import CAMERA_SHOULDER
from simroad.core.validation import check_in_range, check_int_in_range
from simroad.filters._common import (
    FilterResult,
    Planes,
    absent_on_preview,
    camera_to_linear,
    check_filter_image,
    check_odd_size,
    crop_box,
    from_planes,
    linear_to_camera,
    to_planes,
)
from simroad.filters._kernels import (
    LEVELS,
    clipped_top,
    fill_rows,
    level_rows,
    masked_medians,
    median,
    percentile_below,
    row_runs,
    table_rows,
)

__all__ = ["remove_glare"]

_SCALE = 4  # the lobe is estimated on an image this many times smaller than a _REF_WIDTH-wide frame
_REF_WIDTH = 320  # frame width the sizes in pixels refer to; wider frames scale them (1280: x4)
_MIN_TINT = 0.2  # smallest relative channel of the sun's colour (Rayleigh at 5 degrees: ~0.45)
_FLANK = (0.3, 0.7)  # the lobe's flank, as fractions of its peak lift, gives its colour
_MAX_GAIN = 4.0  # largest re-exposure, in linear gain


_TAU_RGB = np.array([0.05, 0.10, 0.23])  # Rayleigh optical depth of the clear atmosphere at ~620, 550, 460 nm
_AIR_MASS = (1.0, 38.0)  # sun overhead .. on the horizon (Kasten & Young)
# The lift over the floor is the specular over the diffuse reflectance: the specular lobe
# does not depend on the road's albedo, which spans 0.04-0.21 (fresh to pale aged asphalt,
# simroad.camera.materials), so a lobe on the palest road lifts it by half as much as on a
# typical one. The lift and warmth tests are set so that a low sun's lobe on pale aged
# asphalt passes (validation worlds 200-249); the shape tests below are what tell a sun's
# lobe from a vehicle or a verge (a white car with its tail lights in snow: warmth 0.41-0.43).
_MIN_WARM = 0.45  # the lobe's R - B lift (99th percentile) over the floor's level: a warm sun
_MIN_CONCENTRATION = 0.33  # share of the lift's column profile within +-3/80 of the width of its peak
_MIN_ROWS = 0.78  # share of the lit rows whose largest lift lies in that band
_MIN_LIT = 0.5  # share of the searched rows that are lit: a lobe runs down the ground towards the camera
_MIN_SYMMETRY = 0.3  # median ratio of the lift 5/80 of the width left and right of the peak (a bell, not a step)
# The sun's reflections on flat ground lie in the vertical plane through the camera and
# the sun: in the image, a line through the nadir, which for a camera pitched 5 degrees
# down and a sun up to 30 degrees off its axis moves by at most 4 pixels of a 320-wide
# frame (one column of the reduced image) over the ground rows. A lit verge or kerb
# converges to the road's vanishing point.
_MAX_DRIFT = 3.5 / 80  # largest shift of the lift's peak column between the lit rows' upper and lower halves, in widths
_CLIP_SPREAD = 6.0 / 255.0  # a clipped pixel: channels within this of each other ...
_CLIP_DEPTH = 8.0 / 255.0  # ... and within this of the frame's brightest lobe pixel


def sun_tint(air_mass: float) -> np.ndarray:
    """Relative RGB of direct sunlight after Rayleigh extinction along ``air_mass``, max 1."""
    c = np.exp(-_TAU_RGB * air_mass)
    return (c / c.max()).astype(np.float32)


def _fit_tint(lift_rgb: np.ndarray) -> np.ndarray:
    """The sun colour on the Rayleigh curve closest to a lift's colour (least squares in log ratios)."""
    rgb = np.maximum(np.asarray(lift_rgb, np.float64), 1e-6)
    logs = np.log(rgb[1:] / rgb[0])  # log G/R, log B/R
    d = _TAU_RGB[1:] - _TAU_RGB[0]
    m = float(-(d @ logs) / (d @ d))
    return sun_tint(min(max(m, _AIR_MASS[0]), _AIR_MASS[1]))


def _find_lobe(least: np.ndarray, warm: np.ndarray, level: float, min_lift: float) -> int | None:
    """Column of a sun's glare lobe (in the reduced image), or None when the frame has none."""
    floor = max(level, 1e-3)
    if percentile_below(least, 99, min_lift * floor) or percentile_below(warm, 99, _MIN_WARM * floor):
        return None
    w = least.shape[1]
    half, off = max(1, round(3 * w / 80)), max(2, round(5 * w / 80))
    profile = least.sum(axis=0)
    c = int(profile.argmax())
    if float(profile[max(0, c - half) : c + half + 1].sum()) < _MIN_CONCENTRATION * max(float(profile.sum()), 1e-9):
        return None
    row_max = least.max(axis=1)
    lit = row_max > 0.2 * float(row_max.max())
    band = least[:, max(0, c - half) : c + half + 1].max(axis=1)
    if float(lit.mean()) < _MIN_LIT or float((band >= 0.8 * row_max)[lit].mean()) < _MIN_ROWS:
        return None
    rows = least[lit]
    peaks = rows.argmax(axis=1)  # from the far rows to the near ones
    k = len(peaks) // 2
    if k and abs(float(np.median(peaks[:k])) - float(np.median(peaks[k:]))) > _MAX_DRIFT * w:
        return None  # slanted towards a vanishing point: a verge or a kerb, not the sun's vertical line
    # the lift off and off columns either side of the peak, 0 beyond the frame
    left = rows[:, c - off] if c >= off else np.zeros(len(rows), rows.dtype)
    right = rows[:, c + off] if c + off < w else np.zeros(len(rows), rows.dtype)
    sym = np.minimum(left, right) / np.maximum(np.maximum(left, right), 1e-9)
    return c if float(median(sym)) >= _MIN_SYMMETRY else None


def _medians(planes: Planes, mask: np.ndarray) -> np.ndarray:
    """``[float(np.median(x[mask])) for x in planes]`` as a float64 array (compiled when ``mask`` is not empty)."""
    if mask.any():
        return masked_medians(np.stack(planes), mask).astype(np.float64)
    return np.array([float(np.median(x[mask])) for x in planes])


def _lobe(lin: Planes, fine: int, wide: int, min_lift: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Lobe amount ``B`` (h, w) and the sun's colour ``t`` (3,) with max 1; None without a lobe.

    Each linear plane is opened with a ``fine`` square (paint, texture) and then with a
    ``wide`` horizontal line: what a narrower bright band adds over that floor is the
    lift. :func:`_find_lobe` decides whether the lift is a sun's lobe; its colour is the
    Rayleigh sun closest to the lifts' ratio on the lobe's flank (a clipped core is
    grey), and ``B`` the largest amount of that colour every channel's lift can hold,
    ``min_c lift_c / t_c``.
    """
    k_fine = np.ones((fine, fine), np.uint8)
    k_wide = np.ones((1, wide), np.uint8)
    opened = [cv2.morphologyEx(p, cv2.MORPH_OPEN, k_fine) for p in lin]
    floors = [cv2.morphologyEx(o, cv2.MORPH_OPEN, k_wide) for o in opened]
    lifts = [o - f for o, f in zip(opened, floors)]
    least = cv2.min(cv2.min(lifts[0], lifts[1]), lifts[2])
    level = float(median(cv2.min(cv2.min(floors[0], floors[1]), floors[2])))
    if _find_lobe(least, np.maximum(lifts[0] - lifts[2], 0.0), level, min_lift) is None:
        return None
    top = float(least.max())
    flank = (least >= _FLANK[0] * top) & (least <= _FLANK[1] * top)  # below a clipped core, above the floor's grain
    t = _fit_tint(_medians(lifts, flank))
    amount = cv2.min(cv2.min(lifts[0] / t[0], lifts[1] / t[1]), lifts[2] / t[2])
    return cv2.GaussianBlur(amount, (0, 0), 1.0), t


def _clipped(planes: Planes, lobe: np.ndarray) -> np.ndarray:
    """The lobe's clipped core: its pixels at the lobe's top level, when that level is grey.

    The scene's radiance clips channel by channel (the warm lobe's red first), and a
    clipped pixel keeps nothing of the road under it. The lobe's brightest pixels are
    a clip when most of them are grey (channels within a few codes): the sun's colour
    is warm, so an unclipped top is not.
    """
    if not lobe.any():
        return lobe
    top = np.empty_like(lobe)
    grey = clipped_top(planes[0], planes[1], planes[2], lobe, _CLIP_DEPTH, np.float32(_CLIP_SPREAD), top)
    return top if 2 * grey >= int(top.sum()) else np.zeros_like(lobe)


def _fill_rows(lin: np.ndarray, holes: np.ndarray) -> None:
    """Replace ``holes`` in each of the (3, H, W) planes, row by row, by the straight line between
    their nearest neighbours (in place; compiled, :func:`~simroad.filters._kernels.fill_rows`)."""
    if holes.any():
        rows, cols = crop_box(holes, 1)
        fill_rows(lin[:, rows, cols], holes[rows, cols])


def _reexpose(
    lin: np.ndarray, gain: np.float32, codes: np.ndarray, rows: np.ndarray, r0: int, shoulder: float, out: list
) -> Planes:  # fmt: skip
    """``linear_to_camera(x * gain)`` of each linear plane ``x`` of the (3, H, W) ``lin``, into
    the planes of ``out`` (new ones for the entries that are None).

    The rows above ``r0`` are the frame's own linear values (the lobe is below): in a
    row of 8-bit levels (``rows``, the levels in ``codes``) each output is one of 256 per
    channel, computed once and looked up.
    """
    table = linear_to_camera(_linear_levels(shoulder), shoulder, gain=gain).reshape(-1)
    out = list(out)
    for c, (x, code, ok) in enumerate(zip(lin, codes, rows)):
        o = out[c] = np.empty_like(x) if out[c] is None else out[c]
        o[r0:] = linear_to_camera(x[r0:], shoulder, gain=gain)
        table_rows(code[:r0], ok[:r0], table, o[:r0])
        for a, b in row_runs(ok[:r0]):
            o[a:b] = linear_to_camera(x[a:b], shoulder, gain=gain)
    return out


@functools.lru_cache(maxsize=8)
def _linear_levels(shoulder: float) -> np.ndarray:
    """The camera's linear signal of the 256 float32 8-bit levels (read-only)."""
    out = camera_to_linear(LEVELS, shoulder).reshape(-1)
    out.setflags(write=False)
    return out


def _to_linear(planes: Planes, shoulder: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`camera_to_linear` of each plane as a (3, H, W) array, with the 8-bit levels (uint8)
    and, per plane and row, whether the row was all levels (bool (3, H)): such a row's values
    are read from a table."""
    h, w = planes[0].shape
    lin, codes, rows = np.empty((3, h, w), np.float32), np.empty((3, h, w), np.uint8), np.empty((3, h), bool)
    for p, x, code, ok in zip(planes, lin, codes, rows):
        level_rows(p, _linear_levels(shoulder), x, code, ok)
        for a, b in row_runs(ok):
            x[a:b] = camera_to_linear(p[a:b], shoulder)
    return lin, codes, rows


def _find(
    planes: Planes, fine: int, wide: int, min_lift: float, top: float, shoulder: float, scale: int
) -> tuple[tuple[np.ndarray, np.ndarray] | None, int]:
    """:func:`_lobe` of the rows from ``top`` down, and the first of those rows.

    ``scale`` and ``wide`` are in pixels of a :data:`_REF_WIDTH`-wide frame: a frame
    ``k`` times wider is reduced ``k * scale`` times with an opening ``k * wide`` long,
    so the lobe is looked for on the same reduced image (80 columns) at every size.
    """
    h, w = planes[0].shape
    r0 = min(int(top * h), h - 1)
    scale = max(1, round(scale * w / _REF_WIDTH))
    wide = max(3, round(wide * w / _REF_WIDTH))
    sh, sw = max(1, (h - r0) // scale), max(1, w // scale)
    small = [cv2.resize(p[r0:], (sw, sh), interpolation=cv2.INTER_AREA) for p in planes]
    wide_small = max(3, min((wide // scale) | 1, 2 * sw + 1))
    return _lobe([camera_to_linear(p, shoulder) for p in small], fine, wide_small, min_lift), r0


def _glare_planes(
    planes: Planes,
    *,
    fine: int,
    wide: int,
    min_lift: float,
    min_excess: float,
    top: float,
    metering_top: float,
    shoulder: float,
    scale: int = _SCALE,
    inplace: bool = False,
    preview: Planes | None = None,
) -> tuple[Planes, np.ndarray]:
    """Core of :func:`remove_glare` on float32 planes; returns (new planes, glare mask).
    ``inplace``: the re-exposed frame is written into the given planes (the caller owns them).
    ``preview``: as for :func:`~simroad.filters.haze._haze_planes` (the lobe is first looked
    for on the preview; :func:`_find` scales to either width)."""
    h, w = planes[0].shape
    if absent_on_preview(planes, preview, lambda p: _find(p, fine, wide, min_lift, top, shoulder, scale)[0] is None):
        return planes, np.zeros((h, w), bool)  # no sun's lobe on the preview
    found, r0 = _find(planes, fine, wide, min_lift, top, shoulder, scale)
    if found is None:
        return planes, np.zeros((h, w), bool)  # no sun's lobe: identity (the planes themselves)
    amount, t = found
    amount = cv2.resize(amount, (w, h - r0), interpolation=cv2.INTER_LINEAR)
    mask = np.zeros((h, w), bool)
    lobe = amount > min_excess
    clipped = _clipped([p[r0:] for p in planes], lobe)
    mask[r0:] = lobe | clipped
    lin, codes, rows = _to_linear(planes, shoulder)
    m0 = min(int(metering_top * h), h - 1)
    before = sum(float(x[m0:].mean()) for x in lin)
    for c in range(3):
        sub = lin[c][r0:]
        sub -= amount * t[c]
        np.maximum(sub, 0.0, out=sub)
    _fill_rows(lin[:, r0:], clipped)  # the clipped core kept nothing of the road: take its sides
    after = sum(float(x[m0:].mean()) for x in lin)
    # The camera metered the lobe: without it, it would have exposed by before/after more.
    gain = np.float32(min(before / max(after, 1e-6), _MAX_GAIN))
    return _reexpose(lin, gain, codes, rows, r0, shoulder, planes if inplace else [None] * 3), mask


def remove_glare(
    image: np.ndarray,
    *,
    fine: int = 3,
    wide: int = 107,
    min_lift: float = 1.5,
    min_excess: float = 0.01,
    top: float = 0.45,
    metering_top: float = 0.0,
    shoulder: float = CAMERA_SHOULDER,
) -> FilterResult:
    """Remove a sun glare lobe by subtracting its additive, sun-coloured radiance; re-expose.

    The improved light filter (the paper's eq. 27 cannot act on grey asphalt).

    1. Decode the frame to the camera's linear signal: the display encoding and the camera's tone exponent
       undone (``p ** (GAMMA / CAMERA_TONE_GAMMA)``), then the inverse of the response curve's shoulder
       ``z = (1 + k) y / (1 + k y)``
       (:mod:`simroad.camera.sensor`).
    2. On the rows from ``top`` down (the ground), reduced to 80 columns (a quarter of a
       320-pixel-wide frame), open each channel with a ``fine`` square (lane paint,
       texture) and then with a ``wide`` horizontal line (the floor); the lift over
       the floor is what a band narrower than ``wide`` adds -- the specular lobe of
       eq. 23. Its colour ``t`` is the
       channels' median lift where the common lift is in its top 5 % (a low sun is
       warm), and the lobe ``B = min_c lift_c / t_c``, lightly smoothed.
    3. If the lobe's 99th percentile is below ``min_lift`` times the floor's median
       level there is no glare: the frame is returned unchanged.
    4. Otherwise each channel loses ``B t_c``, and the frame is re-exposed by the
       ratio of the metered mean (rows from ``metering_top`` down, all channels)
       before and after the removal: the exposure the camera's auto-exposure would
       have chosen without the lobe (at most 4x).

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    fine : int, optional
        Side of the small opening, in pixels of the reduced image (80 columns: a quarter
        of a 320-pixel-wide frame), odd, in [1, 31].
    wide : int, optional
        Length of the horizontal opening, in pixels of a 320-pixel-wide frame (a wider
        frame's opening is as long relative to its width: 107 is a third of it), in
        [3, 4095]: a lobe is narrower, the road and its roadside are wider.
    min_lift : float, optional
        Glare is present when the lobe's 99th percentile exceeds this many times the
        floor's level, in (0, 100].
    min_excess : float, optional
        Smallest linear lobe amount reported in the mask, in (0, 1).
    top : float, optional
        First row searched for the lobe, as a fraction of the height, in [0, 1).
    metering_top : float, optional
        First row of the camera's metering window, as a fraction of the height, in
        [0, 1) (the sensor's ``ae_roi_top``).
    shoulder : float, optional
        The camera response curve's shoulder ``k``, in [0, 20] (the sensor's
        ``tone_shoulder``; 0 for a plain gamma-2.2 frame).

    Returns
    -------
    FilterResult
        ``image``: same shape and dtype as the input, the lobe removed and re-exposed
        (unchanged when no glare is found). ``mask``: bool (H, W), where the lobe
        removed more than ``min_excess``.
    """
    image = check_filter_image("image", image)
    fine = check_odd_size("fine", fine, 1, 31)
    wide = check_int_in_range("wide", wide, 3, 4095)
    min_lift = check_in_range("min_lift", min_lift, 0.0, 100.0, low_inclusive=False)
    min_excess = check_in_range("min_excess", min_excess, 0.0, 1.0, low_inclusive=False, high_inclusive=False)
    top = check_in_range("top", top, 0.0, 1.0, high_inclusive=False)
    metering_top = check_in_range("metering_top", metering_top, 0.0, 1.0, high_inclusive=False)
    shoulder = check_in_range("shoulder", shoulder, 0.0, 20.0)
    out, mask = _glare_planes(
        to_planes(image),
        fine=fine,
        wide=wide,
        min_lift=min_lift,
        min_excess=min_excess,
        top=top,
        metering_top=metering_top,
        shoulder=shoulder,
        inplace=True,
    )
    return FilterResult(from_planes(out, image.dtype), mask)
