"""Shared plumbing of the filters: dtype round trips, channel planes, input checks, the result type.

Every public filter accepts ``uint8`` images (0-255) or float images in [0, 1]
(``float32`` or ``float64``) and hands back the caller's dtype. Internally the filters
work on three contiguous float32 *planes* in [0, 1] -- one (H, W) array per channel --
because OpenCV's box filters and NumPy's element-wise arithmetic are several times
faster on planes than on interleaved (H, W, 3) pixels (and ``cv2.split`` of a float
image costs more than a whole box filter).

A filter's core (``_*_planes``) returns either three new planes or, when it leaves the
image as it is, the very list of planes it was given (no copy; never a mix of the two):
the pipeline then skips the copy and the clip, and the public functions and
:meth:`~simroad.filters.FilterStep.run` hand their callers new arrays either way.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import cv2
import numpy as np

from simroad.core.radiometry import CAMERA_TONE_GAMMA, GAMMA
from simroad.core.validation import IMAGE_DTYPES, check_image, check_int_in_range
from simroad.errors import InvalidParameterError
from simroad.filters._kernels import LEVELS, response_forward, response_inverse, uint8_planes
from simroad.filters._plane_kernels import area_quarter, clip_unit

__all__ = [
    "FilterResult",
    "absent_on_preview",
    "channel_max",
    "channel_min",
    "channel_sum",
    "check_filter_image",
    "check_odd_size",
    "clip_planes",
    "crop_box",
    "from_planes",
    "gate_preview",
    "planes_to_uint8",
    "to_planes",
]

#: Image dtypes every public filter accepts and returns unchanged.

Planes = list  # three float32 (H, W) arrays: R, G, B


class FilterResult(NamedTuple):
    """What every public filter (``remove_*``) returns: the filtered image and its mask.

    A named tuple, so ``image, mask = remove_shadows(frame)`` unpacks it.

    Attributes
    ----------
    image : ndarray, (H, W, 3), the input's dtype (uint8, or float32/float64 in [0, 1])
        The filtered image, a new array.
    mask : ndarray, bool, (H, W)
        The pixels the filter acted on; each filter's docstring says exactly which
        (e.g. the shadow regions it relit, the highlights it found, the pixels the
        rain/snow filter changed). All False when the filter left the image alone.
    """

    image: np.ndarray
    mask: np.ndarray


def check_filter_image(name: str, image: object) -> np.ndarray:
    """Validate a filter input: ``(H, W, 3)`` uint8 or float in [0, 1], finite, non-empty."""
    return check_image(name, image, dtype=IMAGE_DTYPES, channels=3, min_size=1)


def check_odd_size(name: str, value: object, low: int, high: int) -> int:
    """Validate an odd window side in pixels, in ``[low, high]``; return it as an int."""
    size = check_int_in_range(name, value, low, high)
    if size % 2 == 0:
        raise InvalidParameterError(f"{name}: expected an odd window size, got {size}. Use {size + 1}.")
    return size


def to_planes(image: np.ndarray) -> Planes:
    """``(H, W, 3)`` uint8 or float image -> list of three contiguous float32 planes in [0, 1].

    Always a new array: the caller's image is never aliased, so the filters are pure.
    """
    if image.dtype == np.uint8:  # each level's float32(k) * float32(1 / 255), read from a table in one pass
        planar = np.empty((3, *image.shape[:2]), np.float32)
        uint8_planes(image, LEVELS, planar)
    else:
        planar = np.ascontiguousarray(image.transpose(2, 0, 1), dtype=np.float32)
    return [planar[0], planar[1], planar[2]]


def from_planes(planes: Planes, dtype: np.dtype) -> np.ndarray:
    """Clip float32 planes to [0, 1] and interleave them into an (H, W, 3) ``dtype`` image.

    ``uint8`` is rounded to the nearest level, so an untouched pixel survives the
    ``uint8 -> float32 -> uint8`` round trip exactly.
    """
    if dtype == np.uint8:
        return cv2.merge([cv2.convertScaleAbs(np.maximum(p, 0.0), alpha=255.0) for p in planes])
    out = np.stack(planes, axis=-1)
    np.clip(out, 0.0, 1.0, out=out)
    return out.astype(dtype, copy=False)


#: Largest frame (width, height) whose weather gates look at the frame itself. A larger
#: frame's gates first look at a preview of at most this size (:func:`gate_preview`).
GATE_SIZE = (320, 180)


def gate_preview(planes: Planes) -> Planes | None:
    """The planes reduced (``cv2.INTER_AREA``) by the smallest integer factor that fits them
    in :data:`GATE_SIZE`, or None when they fit already.

    A filter's weather gate is one decision for the whole frame (a blue sky, a veil over
    the near rows, a sun's lobe, a colour cast); on a frame larger than :data:`GATE_SIZE`
    the filters take it first on this preview, and only when the preview shows the
    weather on the frame itself (which then decides, so a filter that acts acts as it
    would have). A frame at :data:`GATE_SIZE` or smaller is gated on itself, as before.
    """
    h, w = planes[0].shape
    factor = max(-(-w // GATE_SIZE[0]), -(-h // GATE_SIZE[1]))
    if factor <= 1:
        return None
    size = (max(1, w // factor), max(1, h // factor))
    if factor == 4 and w % 4 == 0 and h % 4 == 0 and all(_plain(p) for p in planes):  # 1280x720: compiled
        out = np.empty((3, size[1], size[0]), np.float32)
        for p, small in zip(planes, out):
            area_quarter(p, small)
        return [out[0], out[1], out[2]]
    return [cv2.resize(p, size, interpolation=cv2.INTER_AREA) for p in planes]


def absent_on_preview(planes: Planes, preview: Planes | None, absent: Callable[[Planes], bool]) -> bool:
    """Whether a frame larger than :data:`GATE_SIZE` shows no weather on its preview:
    ``absent(preview)`` on ``preview`` (made by :func:`gate_preview` when None). A frame
    that fits :data:`GATE_SIZE` is never ruled out here (its gate looks at it itself)."""
    preview = gate_preview(planes) if preview is None else preview
    return preview is not None and absent(preview)


def _plain(p: np.ndarray) -> bool:
    """Whether ``p`` is a C-contiguous float32 array (what the compiled plane loops take)."""
    return p.dtype == np.float32 and p.flags.c_contiguous


def planes_to_uint8(planes: Planes) -> list[np.ndarray]:
    """Float32 planes in [0, 1] -> uint8 planes (rounded, saturated)."""
    return [cv2.convertScaleAbs(np.maximum(p, 0.0), alpha=255.0) for p in planes]


def clip_planes(planes: Planes) -> Planes:
    """Clip each plane to [0, 1] in place and return the list (``np.clip``; compiled for
    contiguous float32 planes, :func:`~simroad.filters._plane_kernels.clip_unit`)."""
    for p in planes:
        if _plain(p):
            clip_unit(p)
        else:
            np.clip(p, 0.0, 1.0, out=p)
    return planes


def channel_max(planes: Planes) -> np.ndarray:
    """Per-pixel ``max_c I^c`` of three planes, (H, W) float32."""
    return cv2.max(cv2.max(planes[0], planes[1]), planes[2])


def channel_min(planes: Planes) -> np.ndarray:
    """Per-pixel ``min_c I^c`` of three planes, (H, W) float32."""
    return cv2.min(cv2.min(planes[0], planes[1]), planes[2])


def channel_sum(planes: Planes) -> np.ndarray:
    """Per-pixel ``sum_c I^c`` of three planes, (H, W) float32."""
    out = planes[0] + planes[1]
    out += planes[2]
    return out


def crop_box(mask: np.ndarray, margin: int) -> tuple[slice, slice]:
    """Bounding box of a non-empty bool (H, W) ``mask`` grown by ``margin`` pixels, clipped to the image."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    h, w = mask.shape
    return (
        slice(max(0, rows[0] - margin), min(h, rows[-1] + 1 + margin)),
        slice(max(0, cols[0] - margin), min(w, cols[-1] + 1 + margin)),
    )


# -------------------------------------------- the camera's response, undone and redone
# The forward model is simroad.camera's sensor with the default camera's response: the
# shoulder ``z = (1 + k) y / (1 + k y)`` on the linear signal ``y`` (``response_curve``),
# then ``z ** (CAMERA_TONE_GAMMA / GAMMA)``: the camera's tone exponent and the display
# encoding of simroad.core.radiometry. Filters that reason in linear light (glare)
# invert it here.
_ENCODE = CAMERA_TONE_GAMMA / GAMMA  # linear (after the shoulder) -> display exponent


def pow_sparing_zeros(x: np.ndarray, power: float) -> np.ndarray:
    """``cv2.pow(x, power)`` of a float32 array, bit for bit, faster where it holds many zeros.

    ``cv2.pow`` takes a slow path for each zero (about eight times the time of another
    value); the zeros are raised as ones and then given ``cv2.pow``'s own result for a
    zero of their sign.
    """
    zero = x == 0
    if not zero.any():
        return cv2.pow(x, power)
    negative = zero & np.signbit(x)
    out = cv2.pow(np.where(zero, np.float32(1.0), x), power)
    plus, minus = cv2.pow(np.array([[0.0, -0.0]], np.float32), power).reshape(-1)
    out[zero] = plus
    out[negative] = minus
    return out


def camera_to_linear(p: np.ndarray, shoulder: float) -> np.ndarray:
    """Display value in [0, 1] -> the camera's linear signal: encoding undone, shoulder undone (float32).

    ``z = p ** (GAMMA / CAMERA_TONE_GAMMA)`` (``cv2.pow``), then ``z / ((1 + k) - k z)`` in
    float32 (compiled, in place).
    """
    z = cv2.pow(np.ascontiguousarray(p, dtype=np.float32), 1.0 / _ENCODE)
    response_inverse(z, np.float32(1.0 + shoulder), np.float32(shoulder))
    return z


def linear_to_camera(y: np.ndarray, shoulder: float, *, gain: np.float32 | None = None) -> np.ndarray:
    """Inverse of :func:`camera_to_linear`: the response's shoulder, then the encoding (float32, ``y`` clipped to [0, 1]).

    ``c = clip(y, 0, 1)``, ``z = (1 + k) c / (1 + k c)`` in float32, then ``z ** (CAMERA_TONE_GAMMA / GAMMA)``
    (``cv2.pow``). With ``gain`` (float32) it is ``linear_to_camera(y * gain)`` in one pass.
    """
    if y.dtype != np.float32:  # rounded to float32 after the clip, as always
        y = np.clip(y, 0.0, 1.0).astype(np.float32)
    z = np.empty(y.shape, np.float32)
    zeros = response_forward(np.ascontiguousarray(y), np.float32(1.0 if gain is None else gain),
                             np.float32(1.0 + shoulder), np.float32(shoulder), z)  # fmt: skip
    return pow_sparing_zeros(z, _ENCODE) if zeros else cv2.pow(z, _ENCODE)
