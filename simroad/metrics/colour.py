"""How well colour alone separates road from non-road: grey-pixel statistics.

A pixel is *grey* when, measured with OpenCV's HSV conversion of the 8-bit RGB
frame, its saturation ``S < 0.15`` and its value ``0.15 < V < 0.85`` (S and V
scaled to [0, 1]). In road photographs (CamVid, KITTI, ACDC, whole frames with
their road labels) 38-55 % of road pixels and 13-37 % of non-road pixels are grey:
grey does not mean road. A synthetic world where nearly all road and almost no
non-road pixels are grey teaches a detector a rule that fails on real streets.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from simroad.core.validation import check_image, check_mask

__all__ = ["GREY_S_MAX", "GREY_V_RANGE", "GreyCounts", "grey_counts", "grey_mask"]

#: Saturation below which a pixel counts as grey (S in [0, 1]).
GREY_S_MAX = 0.15
#: Open range of value V (in [0, 1]) in which a low-saturation pixel counts as grey.
GREY_V_RANGE = (0.15, 0.85)


def grey_mask(rgb: np.ndarray) -> np.ndarray:
    """Grey pixels of an RGB uint8 frame (H, W, 3): bool (H, W)."""
    check_image("rgb", rgb, dtype="uint8")
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)  # 8-bit: S and V in 0..255
    s, v = hsv[..., 1], hsv[..., 2]
    lo, hi = GREY_V_RANGE
    return (s < GREY_S_MAX * 255.0) & (v > lo * 255.0) & (v < hi * 255.0)


@dataclass(frozen=True)
class GreyCounts:
    """Pixel counts of a set of frames: road, grey road, non-road, grey non-road."""

    road: int = 0
    road_grey: int = 0
    other: int = 0
    other_grey: int = 0

    def __add__(self, o: GreyCounts) -> GreyCounts:
        return GreyCounts(
            self.road + o.road, self.road_grey + o.road_grey, self.other + o.other, self.other_grey + o.other_grey
        )

    @property
    def road_fraction(self) -> float:
        """Fraction of road pixels that are grey (NaN without road pixels)."""
        return self.road_grey / self.road if self.road else float("nan")

    @property
    def other_fraction(self) -> float:
        """Fraction of non-road pixels that are grey (NaN without any)."""
        return self.other_grey / self.other if self.other else float("nan")


def grey_counts(rgb: np.ndarray, road_mask: np.ndarray) -> GreyCounts:
    """Grey-pixel counts of one whole frame against its road mask (bool (H, W))."""
    grey = grey_mask(rgb)
    road_mask = check_mask("road_mask", road_mask, shape=grey.shape)
    road = int(np.count_nonzero(road_mask))
    road_grey = int(np.count_nonzero(grey & road_mask))
    total_grey = int(np.count_nonzero(grey))
    return GreyCounts(road, road_grey, grey.size - road, total_grey - road_grey)
