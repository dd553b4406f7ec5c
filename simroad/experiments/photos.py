"""Photographs and their road masks: a folder of images paired with a folder of masks,
in the mask formats datasets use.

A road mask may be

- black and white: road white (255) on black (0), as ``simroad frames`` writes; grey
  edges (anti-aliasing, JPEG) are read as road above mid-grey;
- 0 and 1: road 1 on 0 (most segmentation code saves masks so; they look black);
- a label image: one channel of class values, road the value ``road_value`` (e.g.
  Cityscapes' labelIds: 7);
- a colour image: road the colour ``road_colour`` (R, G, B; e.g. KITTI road: 255, 0, 255).

The first two are told apart by their values; the last two need their option, and a
mask that looks like either without it is refused, as is a mask with no road pixel,
rather than read as something else.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from simroad.core.validation import check_int_in_range
from simroad.errors import InvalidParameterError
from simroad.experiments.frames import FrameSet

__all__ = ["IMAGE_SUFFIXES", "check_road_colour", "load_image_folder", "read_road_mask"]

#: The file name endings read as images or masks (any case).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: A value on at least this share of a mask's pixels is one of its classes (a region,
#: not the grey edge of one: anti-aliasing and JPEG spread their greys over many values).
_CLASS_SHARE = 0.05
#: In a black-and-white mask every class value lies within this share of the range
#: from black or from white (JPEG ringing and anti-aliasing stay near the two).
_NEAR_END = 0.06
_FORMATS = (
    "road must be white on black (0/255), 1 on 0, the --road-value of a label image or the --road-colour "
    "of a colour mask"
)


def check_road_colour(road_colour: Sequence[int] | str | None) -> tuple[int, int, int] | None:
    """``road_colour`` as three ints in 0-255 (R, G, B), from a sequence or a string
    ``"R,G,B"`` or ``"#RRGGBB"``; None stays None."""
    if road_colour is None:
        return None
    value = road_colour
    if isinstance(value, str):
        text = value.strip()
        try:
            if text.startswith("#") and len(text) == 7:
                value = [int(text[k : k + 2], 16) for k in (1, 3, 5)]
            else:
                value = [int(v) for v in text.split(",")]
        except ValueError:
            value = None  # type: ignore[assignment]
    ok = value is not None and not isinstance(value, (bytes, bytearray)) and len(value) == 3
    ok = ok and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 0 <= v <= 255 for v in value)
    if not ok:
        raise InvalidParameterError(
            f"road_colour: expected the road's colour as R,G,B with each in 0-255 (e.g. 255,0,255) or #RRGGBB, "
            f"got {road_colour!r}."
        )
    r, g, b = (int(v) for v in value)
    return r, g, b


def read_road_mask(
    path: str | os.PathLike,
    *,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
    shape: tuple[int, int] | None = None,
) -> np.ndarray:
    """The road of the mask file ``path`` as a bool array (height, width).

    Without options a mask is read as black and white (road above mid-grey) or as 0
    and 1 (road 1), whichever its values are; ``road_value`` reads a label image (road
    where the value equals it), ``road_colour`` a colour mask (road where the pixel is
    that R, G, B). Refuses, naming the file: one that is not an image or not of
    ``shape`` (height, width; when given), a colour or label image without its option,
    and a mask with no road pixel.
    """
    value, colour = _mask_format(road_value, road_colour)
    return _decode(_read(path, shape, "its image"), str(path), value, colour)


def _mask_format(
    road_value: int | None, road_colour: Sequence[int] | str | None
) -> tuple[int | None, tuple[int, int, int] | None]:
    """The mask options checked once, before any file is read: (road_value, RGB colour)."""
    colour = check_road_colour(road_colour)
    if road_value is not None and colour is not None:
        raise InvalidParameterError(
            "road_value: give road_value (a label image) or road_colour (a colour mask), not both."
        )
    if road_value is not None:
        check_int_in_range("road_value", road_value, 0, 65535)
    return road_value, colour


def _read(path: str | os.PathLike, shape: tuple[int, int] | None, image: str) -> np.ndarray:
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise InvalidParameterError(f"masks: could not read {str(path)!r} as an image.")
    if shape is not None and raw.shape[:2] != tuple(shape):
        raise InvalidParameterError(
            f"masks: {Path(path).name} is {raw.shape[1::-1]} but {image} is {tuple(shape)[::-1]} (width x height)."
        )
    return raw


def _decode(raw: np.ndarray, name: str, road_value: int | None, colour: tuple[int, int, int] | None) -> np.ndarray:
    """The road of a mask's pixels ``raw`` (as read), with options checked by :func:`_mask_format`."""
    if raw.ndim == 3 and raw.shape[2] == 4:
        raw = raw[..., :3]  # the alpha channel of a PNG says nothing about the road
    if raw.ndim == 3 and raw.shape[2] == 1:
        raw = raw[..., 0]
    if raw.ndim == 3 and (raw == raw[..., :1]).all():
        raw = raw[..., 0]  # a grey mask saved in colour
    if colour is not None:
        rgb = raw[..., ::-1] if raw.ndim == 3 else np.repeat(raw[..., None], 3, axis=-1)
        road = (rgb == np.array(colour, dtype=rgb.dtype)).all(axis=-1)
        return _some_road(road, name, f"no pixel has the colour {colour}")
    if raw.ndim == 3:
        raise InvalidParameterError(
            f"masks: {name} is a colour image ({_colours(raw)}): pass --road-colour R,G,B, the road's colour "
            "(KITTI road masks: 255,0,255)."
        )
    if raw.dtype not in (np.uint8, np.uint16):
        raise InvalidParameterError(f"masks: {name} holds {raw.dtype} values; expected an 8- or 16-bit image.")
    full = 255 if raw.dtype == np.uint8 else 65535
    if road_value is not None:
        check_int_in_range("road_value", road_value, 0, full)
        return _some_road(raw == road_value, name, f"no pixel has the value {road_value}")
    values, counts = np.unique(raw, return_counts=True)
    if int(values[-1]) <= 1:
        return _some_road(raw == 1, name, "it is all 0")
    classes = values[counts >= _CLASS_SHARE * raw.size]
    if len(classes) > 2 or any(_NEAR_END * full < v < (1.0 - _NEAR_END) * full for v in classes):
        shown = ", ".join(str(int(v)) for v in classes[:8]) + (", ..." if len(classes) > 8 else "")
        raise InvalidParameterError(
            f"masks: {name} looks like a label image (values {shown} each cover 5 % of it or more), not "
            "black and white: pass --road-value N, the road's value (Cityscapes labelIds: 7)."
        )
    return _some_road(raw > full // 2, name, "it has no pixel above mid-grey")


def _some_road(road: np.ndarray, name: str, why: str) -> np.ndarray:
    if not road.any():
        raise InvalidParameterError(f"masks: {name} marks no road pixel ({why}); {_FORMATS}.")
    return road


def _colours(bgr: np.ndarray) -> str:
    """The most common colours of a BGR image, as ``(R, G, B) share`` text."""
    flat = bgr.reshape(-1, 3)[:, ::-1]
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    order = np.argsort(-counts)[:3]
    return ", ".join(f"{tuple(int(c) for c in colours[k])} {100 * counts[k] / len(flat):.0f} %" for k in order)


def load_image_folder(
    images: str | os.PathLike,
    masks: str | os.PathLike,
    *,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
) -> FrameSet:
    """Pair ``images/NAME.*`` with ``masks/NAME.*``, each mask read by
    :func:`read_road_mask` (``road_value``, ``road_colour`` as there).

    Mask files may also be named like ``road_0000.png`` for ``frame_0000.png`` (the
    layout ``simroad frames`` writes); ``images`` and ``masks`` may then be one folder
    (a mask file is never taken for an image). Refuses an image without a mask, by
    name, and masks of another size than their image.
    """
    value, colour = _mask_format(road_value, road_colour)
    idir, mdir = Path(images), Path(masks)
    for name, d in (("images", idir), ("masks", mdir)):
        if not d.is_dir():
            raise InvalidParameterError(f"{name}: {str(d)!r} is not a directory.")
    mask_files = {p.stem: p for p in mdir.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES}
    taken = {p.resolve() for p in mask_files.values()} if idir.resolve() == mdir.resolve() else set()
    pairs, missing = [], []
    for p in sorted(q for q in idir.iterdir() if q.suffix.lower() in IMAGE_SUFFIXES):
        if p.resolve() in taken and p.stem.startswith("road_"):
            continue  # a mask in the one-folder layout
        names = (p.stem, p.stem.replace("frame_", "road_"))
        m = next((q for q in map(mask_files.get, names) if q is not None and q.resolve() != p.resolve()), None)
        if m is None:
            missing.append(p.name)
        else:
            pairs.append((p, m))
    if missing:
        shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        raise InvalidParameterError(
            f"masks: no mask in {str(mdir)!r} for {shown} (a mask has the image's name, or road_N for frame_N); "
            "add the masks or move those images out."
        )
    if not pairs:
        raise InvalidParameterError(f"images: no image in {str(idir)!r}.")
    out = FrameSet()
    for p, m in pairs:
        bgr = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if bgr is None:
            raise InvalidParameterError(f"images: could not read {str(p)!r} as an image.")
        road = _decode(_read(m, bgr.shape[:2], p.name), str(m), value, colour)
        out.images.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        out.masks.append(road)
        out.noise_masks.append({})
        out.valid.append(np.ones(road.shape, bool))
        out.source.append((p.name, 0, 0))
    return out
