"""Colour referenced to the road ahead, and lane markings kept apart (not in §III).

Why
---
A real camera's auto-exposure and white balance follow the whole scene: the same
asphalt comes out at V 0.12 in one frame and 0.42 in the next, tinted by the sky and
the balance (docs/realism.md). A classifier of absolute colours, such as the paper's
SVM on HSI, then has to call road everything from dark to pale grey, and concrete
verges, shoulders and sidewalks fall inside that range. Road detectors since Dahlkamp
et al. (2006, "Self-supervised monocular road detection in desert terrain") and
Alvarez & Lopez (2011, "Road detection based on illuminant invariance") take their
reference from a patch ahead of the vehicle that is road by assumption; here that
patch sets a per-channel gain (a von Kries adaptation) that brings its median colour
to a fixed grey, :data:`ROAD_AHEAD_LEVEL`, before the features are computed. The
classifier then learns colours *relative to the road the car stands on*, which is
what separates a pale verge from the road in any exposure.

Lane markings are road and are classified as road, and a white edge line touching a
pale verge joins the two into one component. :func:`marking_mask` finds thin bright
lines (a morphological top-hat, width scaled with the image); the ego's component is
taken without them and the markings that touch it are added back
(:func:`~simroad.detector.morphology.ego_component_apart`).

Both belong to :class:`~simroad.detector.RoadDetector`'s ``normalize="road_ahead"``
(the shipped model) and to the ``"improved"`` variant's morphology; ``normalize="none"``
and ``filter_variant="paper"`` are §III as printed.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = [
    "MARKING_CONTRAST",
    "NORMALIZATIONS",
    "ROAD_AHEAD_COLS",
    "ROAD_AHEAD_LEVEL",
    "ROAD_AHEAD_ROWS",
    "marking_mask",
    "normalize_planes",
    "normalize_rows",
    "road_ahead_gains",
]

#: The detector's ``normalize`` choices: none (the paper's absolute colours), or a
#: per-channel gain referenced to the road ahead.
NORMALIZATIONS = ("none", "road_ahead")
#: Rows of the reference patch, as fractions of the image height: the road just ahead
#: of the bonnet, below every horizon of the camera mounts simroad supports.
ROAD_AHEAD_ROWS = (0.80, 0.97)
#: Columns of the reference patch, as fractions of the width: the ego's lane.
ROAD_AHEAD_COLS = (0.38, 0.62)
#: The 8-bit level the patch's median colour is brought to in every channel: a grey
#: near the median road of real photographs (V 0.30 -> 77) with headroom for pale
#: surfaces.
ROAD_AHEAD_LEVEL = 100
#: Largest share of the reference patch left out of its median (``exclude``); beyond it
#: the whole patch is used, so a frame always has a reference.
_MAX_EXCLUDED = 0.75
#: Top-hat height (8-bit levels, after normalisation) above which a thin line is a
#: marking: paint against asphalt is 60-150 levels, texture and cracks stay under 10.
MARKING_CONTRAST = 15
#: Top-hat width at 320 pixels of image width (scaled with the width, odd, >= 3):
#: wider than the near edge lines (3-6 px), narrower than the lane.
_MARKING_WIDTH_320 = 9


def _patch(height: int, width: int) -> tuple[slice, slice]:
    r0, r1 = (int(f * height) for f in ROAD_AHEAD_ROWS)
    c0, c1 = (int(f * width) for f in ROAD_AHEAD_COLS)
    return slice(r0, max(r1, r0 + 1)), slice(c0, max(c1, c0 + 1))


def road_ahead_gains(planes: list[np.ndarray], exclude: np.ndarray | None = None) -> np.ndarray:
    """Per-channel gains that bring the reference patch's median to :data:`ROAD_AHEAD_LEVEL`.

    Parameters
    ----------
    planes : list of three ndarray (H, W)
        R, G, B as uint8 (0-255) or float in [0, 1].
    exclude : ndarray, bool, (H, W), optional
        Pixels that do not show the road's own colour: where the light filter took out
        a sun's reflection, which runs down the ego's lane towards the camera. Left out
        of the median unless they are more than :data:`_MAX_EXCLUDED` of the patch.

    Returns
    -------
    ndarray, float64, (3,)
        Multiply a channel in [0, 1] by its gain. A black patch (median below one
        8-bit level) counts as one level, so the gain stays finite.
    """
    rows, cols = _patch(*planes[0].shape)
    keep = None
    if exclude is not None and exclude[rows, cols].any():
        keep = ~exclude[rows, cols]
        if keep.mean() < 1.0 - _MAX_EXCLUDED:
            keep = None
    scale = 255.0 if planes[0].dtype == np.uint8 else 1.0
    med = np.array([float(np.median(p[rows, cols] if keep is None else p[rows, cols][keep])) / scale for p in planes])
    return (ROAD_AHEAD_LEVEL / 255.0) / np.maximum(med, 1.0 / 255.0)


def normalize_planes(planes: list[np.ndarray], normalize: str, exclude: np.ndarray | None = None) -> list[np.ndarray]:
    """The planes as the classifier sees them: unchanged for ``"none"``, else float32
    planes in [0, 1] scaled by :func:`road_ahead_gains` (with ``exclude``) and clipped."""
    if normalize == "none":
        return planes
    gains = road_ahead_gains(planes, exclude)
    out = []
    for p, g in zip(planes, gains):
        unit = g / 255.0 if p.dtype == np.uint8 else g
        q = p.astype(np.float32) * np.float32(unit)
        np.clip(q, 0.0, 1.0, out=q)
        out.append(q)
    return out


def normalize_rows(
    rgb: np.ndarray, shape: tuple[int, int], normalize: str, exclude: np.ndarray | None = None
) -> np.ndarray:
    """:func:`normalize_planes` for colours as (H * W, 3) float rows in [0, 1] of an
    image of ``shape`` (H, W)."""
    if normalize == "none":
        return rgb
    img = rgb.reshape(*shape, 3)
    gains = road_ahead_gains([img[..., c] for c in range(3)], exclude)
    return np.clip(rgb * gains, 0.0, 1.0)


def marking_mask(planes: list[np.ndarray]) -> np.ndarray:
    """Thin bright lines -- lane markings -- of an image given as R, G, B planes.

    A white top-hat of the mean of the planes, as wide as :data:`_MARKING_WIDTH_320`
    at 320 pixels and in proportion otherwise, above :data:`MARKING_CONTRAST` levels.

    Returns
    -------
    ndarray, bool, (H, W)
    """
    w = planes[0].shape[1]
    scale = 1.0 if planes[0].dtype == np.uint8 else 255.0
    grey = (planes[0].astype(np.float32) + planes[1] + planes[2]) * np.float32(scale / 3.0)
    k = max(3, int(round(_MARKING_WIDTH_320 * w / 320.0)) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
    return cv2.morphologyEx(grey, cv2.MORPH_TOPHAT, kernel) > MARKING_CONTRAST
