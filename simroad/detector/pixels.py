"""The detector's pixels: validated training sets, balanced pixel sampling, and the filtered colours the SVM sees."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simroad.core.validation import IMAGE_DTYPES, check_image, check_mask, normalize_rng
from simroad.detector.reference import normalize_rows
from simroad.errors import InvalidParameterError
from simroad.filters._common import planes_to_uint8, to_planes
from simroad.filters.pipeline import _filter_planes_masks, filter_planes_masks

__all__ = [
    "MIN_IMAGE_SIZE",
    "check_training_set",
    "filtered_rgb_masks",
    "filtered_table_planes_masks",
    "filtered_uint8_planes",
    "filtered_uint8_planes_masks",
    "sample_pixels",
]

#: Smallest image side the detector accepts, in pixels.
MIN_IMAGE_SIZE = 8
#: Image dtypes the detector accepts (uint8, or float in [0, 1]).


def check_training_set(
    images: Sequence[np.ndarray] | np.ndarray, masks: Sequence[np.ndarray] | np.ndarray
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Validate training images (sequence or (N, H, W, 3)) and their bool road masks, one per image."""
    if isinstance(images, np.ndarray) and images.ndim == 3:
        raise InvalidParameterError(
            f"images: expected a sequence of (H, W, 3) images or an (N, H, W, 3) array, got "
            f"one array of shape {images.shape}. Wrap a single image in a list: [image]."
        )
    images, masks = _as_list("images", images), _as_list("masks", masks)
    if not images:
        raise InvalidParameterError("images: expected at least one training image, got none.")
    if len(images) != len(masks):
        raise InvalidParameterError(
            f"masks: expected one mask per image ({len(images)} images), got {len(masks)} masks."
        )
    imgs, msks = [], []
    for k, (img, msk) in enumerate(zip(images, masks)):
        img = check_image(f"images[{k}]", img, dtype=IMAGE_DTYPES, channels=3, min_size=MIN_IMAGE_SIZE)
        imgs.append(img)
        msks.append(check_mask(f"masks[{k}]", msk, shape=img.shape[:2]))
    return imgs, msks


def _as_list(name: str, items: object) -> list:
    if isinstance(items, np.ndarray):
        return list(items)
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence):
        raise InvalidParameterError(
            f"{name}: expected a sequence (list or tuple) of arrays or one stacked array, got {type(items).__name__}."
        )
    return list(items)


def sample_pixels(
    images: list[np.ndarray],
    masks: list[np.ndarray],
    filters: tuple[str, ...],
    n_max: int,
    rng: np.random.Generator | int,
    variant: str = "improved",
    normalize: str = "none",
) -> tuple[np.ndarray, np.ndarray]:
    """Balanced random pixels: up to ``n_max / (2 N)`` road and non-road pixels per image.

    Returns the filtered (and ``normalize``-d, :mod:`simroad.detector.reference`) colours (M, 3) float64 in [0, 1] and their labels (M,) int
    (1 = road).
    """
    rng = normalize_rng(rng)
    per = max(1, -(-n_max // (2 * len(images))))
    xs, ys = [], []
    for img, msk in zip(images, masks):
        rgb, acted = filtered_rgb_masks(img, filters, variant)
        rgb = normalize_rows(rgb, img.shape[:2], normalize, acted.get("light"))
        flat = msk.ravel()
        for label in (False, True):
            idx = np.flatnonzero(flat == label)
            if len(idx) > per:
                idx = rng.choice(idx, per, replace=False)
            xs.append(rgb[idx])
            ys.append(np.full(len(idx), int(label)))
    x, y = np.concatenate(xs), np.concatenate(ys)
    if y.min() == y.max():
        kind = "road" if y[0] else "non-road"
        raise InvalidParameterError(
            f"masks: every training pixel is {kind}; the SVM needs both road and "
            "non-road pixels. Add images whose masks contain both."
        )
    return x, y


def filtered_rgb_masks(
    image: np.ndarray, filters: tuple[str, ...], variant: str = "improved"
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Filtered colours of every pixel as (H * W, 3) float64 rows in [0, 1], and each
    filter's mask (where it acted; see :func:`filter_planes_masks`)."""
    if filters:
        planes, masks = filter_planes_masks(to_planes(image), filters, variant)
        return np.stack([p.ravel() for p in planes], axis=1).astype(np.float64), masks
    return image.reshape(-1, 3) / (255.0 if image.dtype == np.uint8 else 1.0), {}


def filtered_uint8_planes(image: np.ndarray, filters: tuple[str, ...], variant: str = "improved") -> list[np.ndarray]:
    """Filtered image as three uint8 (H, W) planes, the lookup table's input."""
    return filtered_uint8_planes_masks(image, filters, variant)[0]


def filtered_uint8_planes_masks(
    image: np.ndarray, filters: tuple[str, ...], variant: str = "improved"
) -> tuple[list[np.ndarray], dict[str, np.ndarray]]:
    """:func:`filtered_uint8_planes`, and each filter's mask (where it acted; see :func:`filter_planes_masks`)."""
    if filters:
        planes, masks = filter_planes_masks(to_planes(image), filters, variant)
        return planes_to_uint8(planes), masks
    if image.dtype != np.uint8:
        return planes_to_uint8([np.ascontiguousarray(image[..., c], dtype=np.float32) for c in range(3)]), {}
    return [image[..., c] for c in range(3)], {}


def filtered_table_planes_masks(
    image: np.ndarray, filters: tuple[str, ...], variant: str = "improved"
) -> tuple[list[np.ndarray], dict[str, np.ndarray]]:
    """The filtered image as the lookup table reads it, and each filter's mask.

    Like :func:`filtered_uint8_planes_masks`, without the 8-bit copy: the filtered
    float32 planes (the table rounds them to 8-bit levels as :func:`planes_to_uint8`
    does), or the uint8 image's own planes when no filter runs.
    """
    if filters:
        return _filter_planes_masks(to_planes(image), filters, variant, owned=True)
    if image.dtype != np.uint8:
        return [np.ascontiguousarray(image[..., c], dtype=np.float32) for c in range(3)], {}
    return [image[..., c] for c in range(3)], {}
