"""The sensor's exposure control and colour: pure maths on :class:`SensorParams`.

The white balance's cast for a scene's daylight, the centre-weighted meter on the
encoded frame, the auto-exposure's update, and the decoding of the rendered frame
(with its over-range level) the sensor exposes from.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from simroad.camera._chroma_kernel import chroma_merge, chroma_split
from simroad.camera.sensor_params import SensorParams
from simroad.core.daylight import CCT_RANGE_K, daylight_rgb, mired_mix
from simroad.core.radiometry import DECODE_TABLE, GAMMA
from simroad.core.validation import check_in_range

__all__ = [
    "OVER_RANGE",
    "SENSOR_DECODE",
    "ChromaScratch",
    "auto_exposure_update",
    "metered_mean",
    "process_chroma",
    "white_balance_gains",
]

#: Linear radiance the sensor takes a rendered level of 255 for. The rendered frame
#: holds radiance up to its range only (1.0, twice a white surface's); a channel at
#: 255 reached it or more: the sun (10^4-10^5 times white), its bloom, a glint, a
#: street canyon's sky. Taken as at least this, it saturates the full well at any
#: exposure the auto-exposure takes (ev >= -4) instead of turning grey when the
#: exposure drops: the sun clips, as on a real sensor.
OVER_RANGE = 16.0
#: The sensor's decoding of the rendered frame: sRGB to linear, 255 over range.
SENSOR_DECODE = DECODE_TABLE.copy()
SENSOR_DECODE[255] = OVER_RANGE
SENSOR_DECODE.flags.writeable = False


def white_balance_gains(
    params: SensorParams, illuminant_k: float, *, error_mired: float = 0.0, error_tint: float = 0.0
) -> np.ndarray | None:
    """The cast a camera's white balance leaves on a scene lit by daylight of
    ``illuminant_k`` K: per-channel gains (R, G, B), green 1, float32; None when there
    is none (a perfect correction of light of the preset's colour, without error).

    Frames are rendered as a camera perfectly balanced for the scene's light would
    see them; a camera that balances for ``T_c`` instead (``awb_strength`` of the way
    from ``wb_preset_k`` to ``illuminant_k`` in mired, then ``error_mired`` further:
    its estimate's error along the daylight locus) multiplies them by
    ``daylight_rgb(illuminant_k) / daylight_rgb(T_c)``. ``error_tint`` is the
    estimate's smaller error across the locus (log gain of green against red and
    blue: positive is a green cast).
    """
    illuminant_k = check_in_range("illuminant_k", illuminant_k, *CCT_RANGE_K, unit="K")
    if error_mired == 0.0 and error_tint == 0.0 and (params.awb_strength == 1.0 or illuminant_k == params.wb_preset_k):
        return None
    balanced_for = mired_mix(params.wb_preset_k, illuminant_k, params.awb_strength)
    lo, hi = 1e6 / CCT_RANGE_K[1], 1e6 / CCT_RANGE_K[0]
    balanced_for = 1e6 / min(hi, max(lo, 1e6 / balanced_for + error_mired))
    gains = daylight_rgb(illuminant_k) / daylight_rgb(balanced_for)
    gains = gains / gains[1] * math.exp(-error_tint)
    gains[1] = 1.0
    return gains.astype(np.float32)


def metered_mean(out: np.ndarray, top: int = 0) -> float:
    """Centre-weighted mean (0-1) of the encoded frame ``out`` from row ``top`` down.

    The frame is averaged over a 16 x 9 grid of cells and the cells weighted by a
    Gaussian of the distance from the centre of the metering window (standard
    deviation 0.35 of its width and height, 5.5 : 1 from the centre to a corner cell): the
    centre-weighted average metering of dash and automotive cameras, which favours
    what lies ahead over the frame's edges.
    """
    cells = cv2.resize(out[top:], _METER_GRID, interpolation=cv2.INTER_AREA).astype(np.float32).mean(axis=2)
    w = np.where(cells >= _HIGHLIGHT_LEVEL, _METER_WEIGHTS * _HIGHLIGHT_WEIGHT, _METER_WEIGHTS)
    return float((cells * w).sum() / w.sum()) / 255.0


def _meter_weights(nx: int, ny: int, sigma: float = 0.35) -> np.ndarray:
    x = (np.arange(nx) + 0.5) / nx - 0.5
    y = (np.arange(ny) + 0.5) / ny - 0.5
    w = np.exp(-0.5 * ((y[:, None] / sigma) ** 2 + (x[None, :] / sigma) ** 2)).astype(np.float32)
    return w / w.sum()


_METER_GRID = (16, 9)
#: Cells at or above this encoded level (of 255) are highlights (sky, sun, white
#: walls) and count this much less: the meter lets them clip rather than darken the rest.
_HIGHLIGHT_LEVEL = 0.8 * 255.0
_HIGHLIGHT_WEIGHT = 0.25
_METER_WEIGHTS = _meter_weights(*_METER_GRID)


def auto_exposure_update(
    ev: float, measured_mean: float, params: SensorParams, *, target: float | None = None
) -> float:
    """Next frame's exposure (EV): move ``ae_rate`` of the error towards the target.

    ``ev' = clip(ev + rate * GAMMA * log2(target / measured), ev_min, ev_max)``: the
    measured mean is of the encoded output, which moves about ``1 / GAMMA`` of a stop
    per stop of exposure, so without saturation the error shrinks by about
    ``1 - rate`` per frame: a time constant of ``-1 / ln(1 - rate)`` frames (3.5
    frames at the default 0.25).
    """
    if not params.auto_exposure:
        return ev
    measured = max(float(measured_mean), 1e-6)
    goal = params.ae_target_mean if target is None else float(target)
    step = params.ae_rate * GAMMA * math.log2(goal / measured)
    return float(min(max(ev + step, params.ev_min), params.ev_max))  # np.clip's value, without its overhead


def process_chroma(
    out: np.ndarray,
    factor: float,
    denoise_px: float = 0.0,
    *,
    scratch: ChromaScratch | None = None,
) -> None:
    """The chroma stage of a camera's processing, on the encoded frame ``out`` (uint8
    RGB, in place): the chroma ``c - Y`` about the luma (Rec. 601 weights) is smoothed
    by a Gaussian of ``denoise_px`` pixels (none at 0) and scaled by ``factor``:
    ``Y + factor * G(c - Y)``, saturating at 0 and 255.

    Every camera's processor reduces chroma noise far more than luma noise (the eye
    is blind to fine colour detail; video codecs then keep chroma at half resolution,
    4:2:0): a grey road comes out grey, not speckled with colour. Consumer and
    automotive cameras then render colours 10-40 % more saturated than colorimetric
    (a "preferred" reproduction). ``scratch`` (of ``out``'s size) holds the planes of
    the smoothing across frames (fresh ones when None).
    """
    if denoise_px <= 0.0:
        grey = cv2.cvtColor(out, cv2.COLOR_RGB2GRAY)
        cv2.addWeighted(out, float(factor), cv2.merge([grey, grey, grey]), 1.0 - float(factor), 0.0, dst=out)
        return
    if scratch is None or scratch.shape != out.shape[:2]:
        scratch = ChromaScratch(*out.shape[:2])
    frame = out if out.flags.c_contiguous else np.ascontiguousarray(out)
    grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY, dst=scratch.luma)
    chroma_split(frame, grey, scratch.chroma, scratch.luma3)
    cv2.GaussianBlur(scratch.chroma, (0, 0), float(denoise_px), dst=scratch.chroma, borderType=cv2.BORDER_REFLECT)
    chroma_merge(scratch.chroma, scratch.luma3, np.float32(factor), frame)
    if frame is not out:
        out[...] = frame


class ChromaScratch:
    """The chroma smoothing's planes for frames of ``height`` x ``width``: the luma
    (uint8), the chroma and the luma on three channels (float32)."""

    def __init__(self, height: int, width: int) -> None:
        self.shape = (int(height), int(width))
        h, w = self.shape
        self.luma = np.empty((h, w), np.uint8)
        self.chroma = np.empty((h, w, 3), np.float32)
        self.luma3 = np.empty((h, w, 3), np.float32)
