"""Per-camera constants of the weather models, computed once per camera mounting.

Everything here depends only on the :class:`~simroad.camera.CameraConfig` (the camera
is rigidly fixed to the ego), so it is cached by config and reused every frame:
per-pixel view rays, the view geometry of every ground pixel (for specular lobes and
Fresnel terms) and the remap table of the wet road's mirror image.

Frames follow :mod:`simroad.camera.geometry`: ego frame X forward, Y right, Z down
(the ground is Z = +h below the camera); camera frame x right, y down, z forward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.noise.model import Limit

SUN_AZIMUTH_LIMIT = Limit(-360.0, 360.0, "degrees", optional=True)
"""Valid sun azimuths (world headings); ``None`` draws one per episode (:func:`draw_sun`)."""

__all__ = [
    "SUN_AZIMUTH_LIMIT",
    "ViewGeometry",
    "draw_sun",
    "ego_rotation",
    "ego_to_world",
    "fresnel_unpolarized",
    "sun_direction_ego",
    "view_geometry",
]


def fresnel_unpolarized(cos_i: np.ndarray, n: float) -> np.ndarray:
    """Fresnel reflectance of unpolarised light from air onto a medium of index ``n``.

    Parameters
    ----------
    cos_i : ndarray
        Cosine of the angle of incidence, in [0, 1].
    n : float
        Refractive index (1.33 for water).
    """
    c = np.clip(cos_i, 1e-6, 1.0)
    s2 = 1.0 - c * c
    ct = np.sqrt(np.maximum(1.0 - s2 / (n * n), 0.0))
    rs = ((c - n * ct) / (c + n * ct)) ** 2
    rp = ((n * c - ct) / (n * c + ct)) ** 2
    return 0.5 * (rs + rp)


@dataclass(frozen=True, eq=False)
class ViewGeometry:
    """Constants of one camera mounting (see the module docstring for frames).

    Attributes
    ----------
    R_ego : ndarray (3, 3)
        Rotation ego -> camera (rows are the camera axes in ego coordinates).
    fx, fy, cx, cy : float
        Intrinsics in pixels.
    height_m, forward_m : float
        Camera height above the road and ahead of the ego centre, m.
    ray_planes : tuple of three ndarray float32 (H, W)
        X, Y and Z components of every pixel's unit ray in the ego frame (Z is the
        cosine between the ground normal and the direction back to the camera).
    ray_planes_half : tuple of three ndarray float32 (ceil(H/2), ceil(W/2))
        The rays of every other row and column (for smooth fields computed at half
        resolution and upsampled).
    ground : ndarray bool (H, W)
        Pixels whose ray meets the ground within range.
    fresnel_water : ndarray float32 (H, W)
        Fresnel reflectance of a water film for the pixel's viewing angle.
    mirror_map : tuple of two ndarray float32 (H, W)
        ``cv2.remap`` maps: the pixel that sees the mirror direction of each ground
        pixel's ray (environment treated as distant).
    ground_xy : ndarray float32 (H, W, 2)
        Ego-frame ground point (X forward, Y right) of every pixel, metres from the
        ego centre; 0 where the pixel sees no ground.
    footprint : ndarray (N, 2)
        Convex hull of the visible ground in ego (X, Y), metres from the ego centre.
    half_fov_x, half_fov_y : float
        Half fields of view in rad.
    """

    config: CameraConfig
    R_ego: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    height_m: float
    forward_m: float
    ray_planes: tuple[np.ndarray, np.ndarray, np.ndarray]
    ray_planes_half: tuple[np.ndarray, np.ndarray, np.ndarray]
    ground: np.ndarray
    fresnel_water: np.ndarray
    mirror_map: tuple[np.ndarray, np.ndarray]
    ground_xy: np.ndarray
    footprint: np.ndarray
    half_fov_x: float
    half_fov_y: float

    def ego_to_image(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Project camera-relative ego points (N, 3) -> (u, v, z_cam)."""
        pc = pts @ self.R_ego.T
        z = pc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.fx * pc[:, 0] / z + self.cx
            v = self.fy * pc[:, 1] / z + self.cy
        return u, v, z


def ego_to_world(xy: np.ndarray, pose: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """World (x, y) of ego-frame ground points ``xy`` (..., 2) for ego ``pose``."""
    x0, y0, h = pose
    c, s = math.cos(h), math.sin(h)
    X, Y = xy[..., 0], xy[..., 1]
    return x0 + c * X - s * Y, y0 + s * X + c * Y


def ego_rotation(pitch_deg: float) -> np.ndarray:
    """Rotation ego -> camera for a camera pitched ``pitch_deg`` down."""
    p = math.radians(pitch_deg)
    sp, cp = math.sin(p), math.cos(p)
    return np.array([[0.0, 1.0, 0.0], [-sp, 0.0, cp], [cp, 0.0, sp]])


@lru_cache(maxsize=16)
def _geometry_for(config: CameraConfig) -> ViewGeometry:
    cam = PinholeCamera(config)
    K = cam.K
    R = ego_rotation(config.pitch_deg)
    H, W = config.height, config.width
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    rays_cam = np.stack([u, v, np.ones_like(u)], axis=-1) @ np.linalg.inv(K).T
    rays = rays_cam @ R
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    ground = cam.ground_valid.copy()
    cos_view = np.where(ground, rays[..., 2], 0.0)
    fres = np.where(ground, fresnel_unpolarized(cos_view, 1.333), 0.0)
    mirror = rays.copy()
    mirror[..., 2] *= -1.0
    mc = mirror @ R.T
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = K[0, 0] * mc[..., 0] / mc[..., 2] + K[0, 2]
        mv = K[1, 1] * mc[..., 1] / mc[..., 2] + K[1, 2]
    bad = ~ground | (mc[..., 2] <= 1e-6) | ~np.isfinite(mu) | ~np.isfinite(mv)
    mu = np.where(bad, u, np.clip(mu, -1, W))
    mv = np.where(bad, v, np.clip(mv, -1, H))
    t = config.mount_height_m / np.where(ground, rays[..., 2], 1.0)
    gxy = np.where(ground[..., None], np.stack([t * rays[..., 0] + config.forward_offset_m, t * rays[..., 1]], -1), 0.0)
    hull = cv2.convexHull(gxy[ground].astype(np.float32)).reshape(-1, 2).astype(float)
    hull = np.vstack([hull, [[config.forward_offset_m, 0.0]]])
    return ViewGeometry(
        config=config,
        R_ego=R,
        fx=float(K[0, 0]),
        fy=float(K[1, 1]),
        cx=float(K[0, 2]),
        cy=float(K[1, 2]),
        height_m=config.mount_height_m,
        forward_m=config.forward_offset_m,
        ray_planes=_planes(rays),
        ray_planes_half=_planes(rays[::2, ::2]),
        ground=ground,
        fresnel_water=fres.astype(np.float32),
        mirror_map=(mu.astype(np.float32), mv.astype(np.float32)),
        ground_xy=gxy.astype(np.float32),
        footprint=hull,
        half_fov_x=math.atan((W / 2) / K[0, 0]),
        half_fov_y=math.atan((H / 2) / K[1, 1]),
    )


def _planes(rays: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The x, y and z components of (H, W, 3) rays as contiguous float32 planes."""
    x, y, z = (np.ascontiguousarray(rays[..., k], dtype=np.float32) for k in range(3))
    return x, y, z


def view_geometry(camera: PinholeCamera) -> ViewGeometry:
    """The cached :class:`ViewGeometry` of a camera's mounting."""
    return _geometry_for(camera.config)


def sun_direction_ego(azimuth_rad: float, elevation_rad: float, heading_rad: float) -> np.ndarray:
    """Unit vector towards the sun in the ego frame (X forward, Y right, Z down).

    ``azimuth_rad`` is the world heading angle of the sun's horizontal direction
    (0 = world +x, pi/2 = world +y, the same convention as a vehicle heading).
    """
    phi = azimuth_rad - heading_rad
    ce = math.cos(elevation_rad)
    return np.array([ce * math.cos(phi), ce * math.sin(phi), -math.sin(elevation_rad)])


def draw_sun(rng: np.random.Generator, azimuth_deg: float | None, elevation_deg: float) -> tuple[float, float]:
    """The episode's sun as ``(azimuth, elevation)`` in radians.

    ``azimuth_deg`` is a world heading in degrees, or ``None`` to draw one uniformly
    from ``rng`` (one draw); ``elevation_deg`` is above the horizon, degrees.
    """
    az = rng.uniform(0.0, 2 * math.pi) if azimuth_deg is None else math.radians(azimuth_deg)
    return (az, math.radians(elevation_deg))
