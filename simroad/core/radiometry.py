"""Radiometry of the weather models: sRGB frames to linear radiance and back.

Frames are treated as sRGB-encoded with a display gamma of 2.2. Every model works on
*linear* relative radiance (float32, 1.0 = a white Lambertian surface under the
scene's illumination, which is the camera's exposure reference), because light adds
and attenuates linearly there: the paper's eq. 19 blend, Koschmieder's law and the
dichromatic model's sum (eq. 23) are all statements about radiance. The runner
(:func:`simroad.noise.model.run_models`) decodes the frame once, lets each model act
on the linear buffer, and encodes once; values above 1.0 clip to 255, which is the
sensor's saturation.

A model's ground-truth mask marks the pixels its stages changed by at least
:data:`MASK_THRESHOLD` = 8 grey levels (of 255) on any channel of the encoded frame
(:func:`change_mask`).
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad.core.validation import check_int_in_range
from simroad.errors import InvalidParameterError

__all__ = [
    "CAMERA_SHOULDER",
    "CAMERA_TONE_GAMMA",
    "DECODE_TABLE",
    "GAMMA",
    "MASK_THRESHOLD",
    "as_uint8",
    "change_mask",
    "linear_to_srgb",
    "srgb_to_linear",
]

GAMMA = 2.2
MASK_THRESHOLD = 8

#: The default camera's response curve (simroad.camera.profile.CameraProfile and the
#: filters' model of the camera): the shoulder ``k`` of ``(1 + k) y / (1 + k y)`` ...
CAMERA_SHOULDER = 1.0
#: ... and the exponent applied after it, before the sRGB encoding: a camera's
#: contrast (display value = ``shoulder(y) ** (CAMERA_TONE_GAMMA / GAMMA)``).
CAMERA_TONE_GAMMA = 1.6

#: sRGB level (0..255) -> linear radiance, float32 (256,): the decoding of a uint8 frame.
DECODE_TABLE = ((np.arange(256, dtype=np.float64) / 255.0) ** GAMMA).astype(np.float32)


def _check_frame(name: str, image: object, dtypes: tuple[str, ...]) -> None:
    """A cheap per-frame check (type, dtype, shape, at least one pixel; no pass over the pixels)."""
    if not isinstance(image, np.ndarray):
        raise InvalidParameterError(f"{name}: expected a numpy array (H, W, 3), got {type(image).__name__}.")
    if image.dtype.name not in dtypes:
        raise InvalidParameterError(f"{name}: expected dtype {' or '.join(dtypes)}, got {image.dtype}.")
    if image.ndim != 3 or image.shape[2] != 3:
        raise InvalidParameterError(f"{name}: expected an array of shape (H, W, 3), got shape {image.shape}.")
    if image.size == 0:
        raise InvalidParameterError(f"{name}: expected at least 1x1 pixels, got shape {image.shape}.")


def srgb_to_linear(image: np.ndarray) -> np.ndarray:
    """Decode an sRGB frame to linear relative radiance.

    Parameters
    ----------
    image : ndarray, uint8 (H, W, 3) in 0..255, or float32/float64 in [0, 1]

    Returns
    -------
    ndarray, float32, (H, W, 3)
        Linear radiance, 1.0 = white.
    """
    _check_frame("image", image, ("uint8", "float32", "float64"))
    if image.dtype == np.uint8:
        return cv2.LUT(image, DECODE_TABLE)
    return np.power(image.astype(np.float32), GAMMA, dtype=np.float32)


def linear_to_srgb(lin: np.ndarray, dtype: np.dtype | type = np.uint8) -> np.ndarray:
    """Encode linear radiance; values above 1.0 saturate (255 for uint8).

    Parameters
    ----------
    lin : ndarray, float32, (H, W, 3)
        Linear radiance (not modified).
    dtype : numpy dtype
        ``uint8`` (0..255) or a float dtype (0..1).

    Returns
    -------
    ndarray, (H, W, 3), of ``dtype``
    """
    _check_frame("lin", lin, ("float32", "float64"))
    # x ** (1/γ) as exp(log(x)/γ): twice as fast as cv2.pow
    x = cv2.log(cv2.max(lin, 1e-7))  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands
    np.multiply(x, np.float32(1.0 / GAMMA), out=x)
    x = cv2.exp(x)
    if np.dtype(dtype) == np.uint8:
        return cv2.convertScaleAbs(x, alpha=255.0)
    return np.minimum(x, 1.0).astype(dtype)


def change_mask(before: np.ndarray, after: np.ndarray, threshold: int = MASK_THRESHOLD) -> np.ndarray:
    """Pixels where two uint8 frames differ by ``>= threshold`` on any channel.

    Parameters
    ----------
    before, after : ndarray, uint8, (H, W, 3)
    threshold : int
        Grey levels (of 255).

    Returns
    -------
    ndarray, bool, (H, W)
    """
    _check_frame("before", before, ("uint8",))
    _check_frame("after", after, ("uint8",))
    if before.shape != after.shape:
        raise InvalidParameterError(f"after: expected the shape of before, {before.shape}, got {after.shape}.")
    check_int_in_range("threshold", threshold, 0, 255)
    d = cv2.absdiff(before, after)
    return np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2]) >= threshold


def as_uint8(image: np.ndarray) -> np.ndarray:
    """A frame as uint8 (H, W, 3): uint8 input as is, float [0, 1] rounded to 0..255."""
    if image.dtype == np.uint8:
        return image
    return np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
