"""Region growing of the road across smooth illumination (an improvement next to §III-D, not the paper).

The paper's morphology keeps the SVM's road component under the ego. Under a low sun
the specular lobe and the exposure it causes (:mod:`simroad.filters.glare`) spread the
road's brightness over 80-210 codes in one frame, and the colour-only SVM keeps only
the part that looks like clear-weather asphalt. But the lobe is *smooth*: from pixel
to pixel the road's colour changes by a code or two, while road edges (grass, kerbs,
walls, vehicles) are steps. Flood filling from the ego's road with a floating range
(``cv2.floodFill``: each pixel joins if it differs from an already joined neighbour by
at most ``tolerance`` codes in every channel) follows the road through the lobe and
stops at its edges.
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad.core.validation import check_image, check_in_range, check_int_in_range, check_mask
from simroad.errors import InvalidParameterError

__all__ = ["GROW_TOLERANCE", "grow_road"]

#: The improved detector's floating range with the light filter on, in 8-bit codes per channel.
GROW_TOLERANCE = 2.0

_EGO_ROWS = 8  # the ego window: last 1/8 of the rows, middle third of the columns
_EGO_COLS = 3
_MAX_SEEDS = 32


def _as_uint8(image: np.ndarray) -> np.ndarray:
    """A checked RGB frame (uint8, or float in [0, 1]) as contiguous uint8."""
    if image.dtype == np.uint8:
        return np.ascontiguousarray(image)
    return (np.clip(image, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _grow(image: np.ndarray, mask: np.ndarray, ground: np.ndarray | None, tolerance: float, scale: int) -> np.ndarray:
    h, w = mask.shape
    sw, sh = max(1, w // scale), max(1, h // scale)
    small = cv2.medianBlur(cv2.resize(image, (sw, sh), interpolation=cv2.INTER_AREA), 3)
    seeds = cv2.resize(mask.view(np.uint8), (sw, sh), interpolation=cv2.INTER_NEAREST)
    filled = np.zeros((sh + 2, sw + 2), np.uint8)
    if ground is not None:  # floodFill never enters a non-zero mask pixel
        filled[1:-1, 1:-1][cv2.resize(ground.view(np.uint8), (sw, sh), interpolation=cv2.INTER_NEAREST) == 0] = 1
    c0, c1 = sw // _EGO_COLS, max(sw // _EGO_COLS + 1, sw - sw // _EGO_COLS)
    rows = range(sh - 1, sh - 1 - max(1, sh // _EGO_ROWS), -2)
    step = max(1, (c1 - c0) // 8)
    points = [(x, y) for y in rows for x in range(c0, c1, step) if seeds[y, x]]
    flags = 8 | cv2.FLOODFILL_MASK_ONLY | (2 << 8)
    diff = (float(tolerance),) * 3
    for x, y in points[:_MAX_SEEDS]:
        if not filled[y + 1, x + 1]:
            cv2.floodFill(small, filled, (x, y), 0, diff, diff, flags)
    grown = (filled[1:-1, 1:-1] == 2).view(np.uint8)
    return cv2.resize(grown, (w, h), interpolation=cv2.INTER_NEAREST) > 0


def _across_lobe(mask: np.ndarray, lobe: np.ndarray) -> np.ndarray:
    """The lobe's pixels with road both left and right of them in their row.

    A sun's specular lobe lies on the surface that mirrors it; where the road goes on
    at both sides of it, the lobe is on the road (its clipped core keeps nothing of the
    road's colour, and its steep flanks stop the growth).
    """
    left = np.logical_or.accumulate(mask, axis=1)
    right = np.logical_or.accumulate(mask[:, ::-1], axis=1)[:, ::-1]
    return lobe & left & right


def grow_road(
    image: np.ndarray,
    mask: np.ndarray,
    *,
    ground: np.ndarray | None = None,
    tolerance: float = GROW_TOLERANCE,
    scale: int = 2,
) -> np.ndarray:
    """The road grown from the mask's pixels under the ego across smooth colour changes.

    The image is reduced ``scale`` times (area averaging) and median filtered (3x3,
    sensor noise); from the mask's pixels in the ego window (every other row of the
    last eighth of the rows, eight columns of the middle third) ``cv2.floodFill``
    with a floating range of ``tolerance`` codes per channel grows the road, never
    into pixels outside ``ground``.

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8
        RGB frame.
    mask : ndarray, bool, (H, W)
        The road the ego stands on (the seeds).
    ground : ndarray, bool, (H, W), optional
        Pixels that may be road (below the horizon); None: all.
    tolerance : float, optional
        Largest step between neighbours, in 8-bit codes per channel, in [0, 64].
    scale : int, optional
        Reduction factor, in [1, 8].

    Returns
    -------
    ndarray, bool, (H, W)
        The grown road (seeds included); the caller adds it to its mask.
    """
    image = check_image("image", image, dtype=("uint8",), channels=3)
    mask = np.ascontiguousarray(check_mask("mask", mask))
    if mask.shape != image.shape[:2]:
        raise InvalidParameterError(f"mask: expected the image's shape {image.shape[:2]}, got {mask.shape}.")
    if ground is not None:
        ground = np.ascontiguousarray(check_mask("ground", ground))
        if ground.shape != mask.shape:
            raise InvalidParameterError(f"ground: expected the image's shape {mask.shape}, got {ground.shape}.")
    tolerance = check_in_range("tolerance", tolerance, 0.0, 64.0)
    scale = check_int_in_range("scale", scale, 1, 8)
    return _grow(np.ascontiguousarray(image), mask, ground, tolerance, scale)
