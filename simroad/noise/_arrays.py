"""Small array helpers the weather models share: smoothstep, exp, channel constants, material weights."""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from simroad.noise.context import FrameState

__all__ = ["fast_exp", "gray3", "material_weights", "rgb_scalar", "smoothstep"]


def smoothstep(x: np.ndarray) -> np.ndarray:
    """Cubic smoothstep of ``x`` clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def fast_exp(x: np.ndarray) -> np.ndarray:
    """``exp(x)`` of a float32 array, with ``x`` clipped at -80 first.

    Below about -87 the result is a float32 denormal, which costs the CPU a
    hundred times more per element; ``exp(-80)`` ≈ 2e-35 is zero for any pixel.
    """
    x = np.asarray(x, dtype=np.float32)
    if x.size == 0:  # no ground in view: OpenCV refuses empty arrays
        return x.copy()
    return cv2.exp(cv2.max(x, -80.0))  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands


def rgb_scalar(value: np.ndarray | float) -> tuple[float, float, float, float]:
    """A per-channel constant as an OpenCV scalar (fast, unlike NumPy broadcasting
    over the channel axis)."""
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,))
    return (float(v[0]), float(v[1]), float(v[2]), 0.0)


def gray3(weight: np.ndarray) -> np.ndarray:
    """A float32 (H, W) map repeated over three channels, (H, W, 3)."""
    weight = np.ascontiguousarray(weight, dtype=np.float32)
    if weight.size == 0:  # no ground in view: OpenCV refuses empty arrays
        return np.empty((*weight.shape, 3), np.float32)
    return cv2.cvtColor(weight, cv2.COLOR_GRAY2RGB)


def material_weights(state: FrameState, table: dict[int, float], default_ground: float) -> np.ndarray:
    """Per-pixel weight (H, W) float32 from a material -> weight table.

    Pixels without material information get ``default_ground`` on the ground and 0
    elsewhere; sky and vehicles get 0 unless listed.
    """
    if state.material is None:
        return np.where(state.ground, np.float32(default_ground), np.float32(0.0)).astype(np.float32)
    return cv2.LUT(state.material, _material_lut(tuple(sorted(table.items()))))


@lru_cache(maxsize=32)
def _material_lut(items: tuple[tuple[int, float], ...]) -> np.ndarray:
    lut = np.zeros(256, dtype=np.float32)
    for code, wgt in items:
        lut[code] = wgt
    lut.flags.writeable = False
    return lut
