"""A contiguous piece of the world raster: the array the camera warps, with its mip levels."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["Window"]


@dataclass
class Window:
    """A contiguous piece of the world raster.

    ``rgba`` is uint8 (h, w, 4): RGB colour and, in the 4th channel, the signed
    distance to the road edge encoded as ``128 + 254 * d`` (d in metres, clipped to
    +-0.5 m), so that a bilinear warp followed by ``>= 128`` gives the road surface
    to sub-texel precision. ``material`` is uint8 (h, w). Texel ``(row, col)`` has its
    centre at world ``(x0 + (col + 0.5) * texel_m, y0 + (row + 0.5) * texel_m)``.
    """

    rgba: np.ndarray
    material: np.ndarray
    x0: float
    y0: float
    texel_m: float
    #: Builds mip level ``k`` (>= 1) of this window, or None to downsample ``rgba``.
    level_source: Callable[[int], np.ndarray] | None = field(default=None, repr=False, compare=False)

    @property
    def texel_from_world(self) -> np.ndarray:
        t = self.texel_m
        return np.array([[1 / t, 0, -self.x0 / t - 0.5], [0, 1 / t, -self.y0 / t - 0.5], [0, 0, 1.0]])

    def level(self, k: int) -> np.ndarray:
        """The colour (``rgba``) downsampled ``k`` times with ``cv2.pyrDown`` (cached).

        Level-``k`` texel ``x_k`` sits at level-0 texel ``(x_k + 0.5) * 2**k - 0.5``.
        A window assembled from tiles takes each tile's own levels (built once per
        tile, not per window); a bare window downsamples its ``rgba``.
        """
        levels = self.__dict__.setdefault("_levels", {0: self.rgba})
        if k not in levels:
            if self.level_source is not None:
                levels[k] = self.level_source(k)
            else:
                levels[k] = cv2.pyrDown(self.level(k - 1))
        return levels[k]

    @property
    def alpha(self) -> np.ndarray:
        """The road's signed-distance channel of ``rgba``, contiguous (cached)."""
        a = self.__dict__.get("_alpha")
        if a is None:
            a = self.__dict__["_alpha"] = np.ascontiguousarray(self.rgba[..., 3])
        return a

    def contains(self, xmin: float, ymin: float, xmax: float, ymax: float) -> bool:
        h, w = self.material.shape
        return (
            xmin >= self.x0
            and ymin >= self.y0
            and xmax <= self.x0 + w * self.texel_m
            and ymax <= self.y0 + h * self.texel_m
        )
