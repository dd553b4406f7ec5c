"""The bird's-eye view of the world around the ego (videos and figures; not the camera)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from simroad.camera.vehicles import VehicleBox
from simroad.camera.world import WorldRaster

__all__ = ["render_bev"]


def render_bev(
    world: WorldRaster,
    pose: tuple[float, float, float],
    *,
    size: tuple[int, int] = (240, 320),
    metres_per_px: float = 0.25,
    behind_m: float = 15.0,
    vehicles: Sequence[VehicleBox] = (),
    ego: VehicleBox | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bird's-eye view of the world around the ego, heading pointing up.

    Parameters
    ----------
    size : (width, height)
        Output size in pixels.
    metres_per_px : float
        Ground resolution of the view.
    behind_m : float
        Ground distance shown behind the ego.

    Returns
    -------
    rgb : uint8 (H, W, 3)
    road_mask : bool (H, W)
    """
    W, H = size
    x, y, h = pose
    ch, sh = math.cos(h), math.sin(h)
    fwd, right = np.array([ch, sh]), np.array([-sh, ch])
    ego_px = np.array([W / 2.0, H - behind_m / metres_per_px])
    # world = ego + (row_up * m) * fwd + (col - cx) * m * right
    A = np.zeros((3, 3))
    A[:2, 0] = right * metres_per_px
    A[:2, 1] = -fwd * metres_per_px
    A[:2, 2] = np.array([x, y]) - ego_px[0] * right * metres_per_px + ego_px[1] * fwd * metres_per_px
    A[2, 2] = 1.0
    corners = np.array([[0, 0, 1], [W, 0, 1], [0, H, 1], [W, H, 1]], dtype=float) @ A.T
    win = world.window(*corners[:, :2].min(axis=0), *corners[:, :2].max(axis=0), slot="bev")
    M = (win.texel_from_world @ A)[:2]
    rgba = cv2.warpAffine(win.rgba, M, (W, H), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
    rgb = np.ascontiguousarray(rgba[..., :3])
    road = rgba[..., 3] >= 128
    Ainv = np.linalg.inv(A)
    for v in list(vehicles) + ([ego] if ego is not None else []):
        pts = np.column_stack([v.corners(), np.ones(4)]) @ Ainv.T
        cv2.fillConvexPoly(rgb, np.round(pts[:, :2] * 16).astype(np.int32), v.rgb, shift=4)
    return rgb, road
