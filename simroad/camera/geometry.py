"""Pinhole camera fixed to the ego vehicle, looking at a flat ground plane.

Frames
------
World: highway-env's ground coordinates ``(x, y)`` in metres. highway-env draws them
with ``y`` pointing down the screen, so a lane's positive lateral offset is to the
*right* of its heading; the physical "up" axis is therefore ``-z``.

Camera: OpenCV convention, ``x`` right, ``y`` down, ``z`` forward; pixel ``(u, v)``
is column ``u``, row ``v`` and integer coordinates are pixel centres.

Because the camera is rigidly mounted on the ego and the ground is flat, the
ground-plane-to-image map is a homography, and everything that depends only on the
mounting (per-pixel ground distance, the horizon, the ego-frame ground coordinates of
every pixel) is computed once per camera and reused every frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simroad.core.validation import check_in_range, check_int_in_range
from simroad.errors import InvalidParameterError

__all__ = ["CameraConfig", "PinholeCamera"]


@dataclass(frozen=True)
class CameraConfig:
    """Mounting and optics of the dashboard camera.

    Parameters
    ----------
    width, height : int
        Image size in pixels; width in [16, 1280], height in [16, 720].
    hfov_deg : float
        Horizontal field of view in degrees, in [30, 120].
    mount_height_m : float
        Height of the optical centre above the road in metres, in [0.5, 4].
    pitch_deg : float
        Downward tilt of the optical axis in degrees, in [0, 30].
    forward_offset_m : float
        Position of the camera ahead of the vehicle's centre in metres, in [-3, 3].
    max_range_m : float
        Ground distance in metres beyond which the ground is not drawn (it fades into
        the horizon haze and counts as sky), in [20, 500].
    texel_m : float
        Size of one texel of the ground raster in metres, in [0.02, 0.5].
    """

    width: int = 320
    height: int = 180
    hfov_deg: float = 70.0
    mount_height_m: float = 1.3
    pitch_deg: float = 5.0
    forward_offset_m: float = 0.8
    max_range_m: float = 100.0
    texel_m: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "width", check_int_in_range("width", self.width, 16, 1280))
        object.__setattr__(self, "height", check_int_in_range("height", self.height, 16, 720))
        for name, lo, hi, unit in (
            ("hfov_deg", 30.0, 120.0, "degrees"),
            ("mount_height_m", 0.5, 4.0, "m"),
            ("pitch_deg", 0.0, 30.0, "degrees"),
            ("forward_offset_m", -3.0, 3.0, "m"),
            ("max_range_m", 20.0, 500.0, "m"),
            ("texel_m", 0.02, 0.5, "m"),
        ):
            object.__setattr__(self, name, check_in_range(name, getattr(self, name), lo, hi, unit=unit))


class PinholeCamera:
    """A pinhole camera mounted on the ego vehicle.

    Call :meth:`set_pose` with the ego pose each frame, then map between the image
    and the ground with :meth:`image_to_ground` and :meth:`ground_to_image`.

    Attributes
    ----------
    K : ndarray, shape (3, 3)
        Intrinsic matrix.
    depth : ndarray, float32, shape (H, W)
        Ground distance in metres from the camera to the ground point each pixel
        sees; ``inf`` above the horizon and beyond ``max_range_m``.
    ground_valid : ndarray, bool, shape (H, W)
        Pixels that see the ground within ``max_range_m``.
    horizon_row : float
        Image row of the horizon (may lie outside the image).
    """

    def __init__(self, config: CameraConfig | None = None) -> None:
        self.config = config or CameraConfig()
        c = self.config
        fx = (c.width / 2.0) / math.tan(math.radians(c.hfov_deg) / 2.0)
        self.K = np.array([[fx, 0.0, (c.width - 1) / 2.0], [0.0, fx, (c.height - 1) / 2.0], [0.0, 0.0, 1.0]])
        self.K_inv = np.linalg.inv(self.K)
        pitch = math.radians(c.pitch_deg)
        self.horizon_row = self.K[1, 2] - fx * math.tan(pitch)
        # Ego frame: X forward, Y right, Z down (so the ground is Z = 0 and the
        # camera sits at Z = -h). Rotation ego -> camera, rows are camera axes.
        sp, cp = math.sin(pitch), math.cos(pitch)
        self._R_ego = np.array(
            [
                [0.0, 1.0, 0.0],  # camera x = ego right
                [-sp, 0.0, cp],  # camera y = down, tilted
                [cp, 0.0, sp],  # camera z = forward, tilted down
            ]
        )
        self._cam_ego = np.array([c.forward_offset_m, 0.0, -c.mount_height_m])
        # ego ground (X, Y, 1) -> image: K R ([X, Y, 0] - C), the pose's constant factor
        self._K_ego = self.K @ np.column_stack([self._R_ego[:, 0], self._R_ego[:, 1], -self._R_ego @ self._cam_ego])
        self._ego_ground = self._pixel_ground_map()
        ex, ey = self._ego_ground[..., 0], self._ego_ground[..., 1]
        dist = np.hypot(ex - c.forward_offset_m, ey)
        self.ground_valid = np.isfinite(dist) & (dist <= c.max_range_m)
        self.depth = np.where(self.ground_valid, dist, np.inf).astype(np.float32)
        self.set_pose(0.0, 0.0, 0.0)

    # ------------------------------------------------------------------ pose
    def set_pose(self, x: float, y: float, heading: float) -> None:
        """Place the ego at world ``(x, y)`` (m) with ``heading`` (rad)."""
        self.pose = (float(x), float(y), float(heading))
        ch, sh = math.cos(heading), math.sin(heading)
        # world -> ego rotation (ground plane), ego X forward, Y right
        self._R_we2 = np.array([[ch, sh], [-sh, ch]])
        self._pos = np.array([x, y], dtype=float)
        # Homography world ground (x, y, 1) -> image (homogeneous)
        tx, ty = (-self._R_we2 @ self._pos).tolist()  # world -> ego ground
        A = np.array([[ch, sh, tx], [-sh, ch, ty], [0.0, 0.0, 1.0]])
        self.H_image_from_world = self._K_ego @ A
        self.H_world_from_image = np.linalg.inv(self.H_image_from_world)

    @property
    def position_world(self) -> np.ndarray:
        """Camera position on the ground plane (world x, y) in metres."""
        x, y, h = self.pose
        off = self.config.forward_offset_m
        return np.array([x + off * math.cos(h), y + off * math.sin(h)])

    # --------------------------------------------------------------- mapping
    def _pixel_ground_map(self) -> np.ndarray:
        """Ego-frame ground (X forward, Y right) seen by every pixel; NaN if none."""
        c = self.config
        u, v = np.meshgrid(np.arange(c.width, dtype=float), np.arange(c.height, dtype=float))
        rays_cam = np.stack([u, v, np.ones_like(u)], axis=-1) @ self.K_inv.T
        rays_ego = rays_cam @ self._R_ego  # R^T applied to each ray
        dz = rays_ego[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -self._cam_ego[2] / dz  # reach Z = 0 from Z = -h
        hit = (dz > 1e-9) & np.isfinite(t)
        X = np.where(hit, self._cam_ego[0] + t * rays_ego[..., 0], np.nan)
        Y = np.where(hit, self._cam_ego[1] + t * rays_ego[..., 1], np.nan)
        return np.stack([X, Y], axis=-1)

    def image_to_ground(self, uv: np.ndarray) -> np.ndarray:
        """Map pixel coordinates to world ground coordinates.

        Parameters
        ----------
        uv : array_like, shape (N, 2)
            Pixel coordinates ``(x=column, y=row)``.

        Returns
        -------
        ndarray, float64, shape (N, 2)
            World ``(x, y)`` in metres; NaN for pixels above the horizon, whose
            ground point lies beyond ``max_range_m``, or that are not finite.
        """
        uv = _as_points("uv", uv)
        with np.errstate(divide="ignore", invalid="ignore"):  # non-finite points give NaN
            hom = np.column_stack([uv, np.ones(len(uv))]) @ self.H_world_from_image.T
            # Rays that miss the ground give w <= 0 in the ego Z-down construction;
            # recompute via the ray direction to decide validity.
            rays_cam = np.column_stack([uv, np.ones(len(uv))]) @ self.K_inv.T
            dz = (rays_cam @ self._R_ego)[:, 2]
            xy = hom[:, :2] / hom[:, 2:3]
        cam = self.position_world
        dist = np.hypot(xy[:, 0] - cam[0], xy[:, 1] - cam[1])
        bad = (dz <= 1e-9) | ~np.isfinite(dist) | (dist > self.config.max_range_m)
        xy[bad] = np.nan
        return xy

    def ground_to_image(self, xy: np.ndarray) -> np.ndarray:
        """Map world ground points to pixel coordinates.

        Parameters
        ----------
        xy : array_like, shape (N, 2)
            World ``(x, y)`` in metres on the ground plane.

        Returns
        -------
        ndarray, float64, shape (N, 2)
            Pixel ``(x=column, y=row)``; NaN for points behind the camera or not
            finite. Points in front of the camera but outside the frame get
            coordinates outside it.
        """
        xy = _as_points("xy", xy)
        with np.errstate(divide="ignore", invalid="ignore"):  # non-finite points give NaN
            hom = np.column_stack([xy, np.ones(len(xy))]) @ self.H_image_from_world.T
            uv = hom[:, :2] / hom[:, 2:3]
        uv[hom[:, 2] <= 1e-9] = np.nan
        return uv

    def world_to_camera(self, xyz: np.ndarray) -> np.ndarray:
        """Map world 3-D points ``(x, y, height_m)`` to camera coordinates (N, 3)."""
        xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
        ego2 = (xyz[:, :2] - self._pos) @ self._R_we2.T
        ego = np.column_stack([ego2, -xyz[:, 2]])  # height up -> Z down
        return (ego - self._cam_ego) @ self._R_ego.T

    def camera_to_image(self, pts_cam: np.ndarray) -> np.ndarray:
        """Project camera-frame points (N, 3) with z > 0 to pixels (N, 2)."""
        pts_cam = np.asarray(pts_cam, dtype=float).reshape(-1, 3)
        hom = pts_cam @ self.K.T
        return hom[:, :2] / hom[:, 2:3]

    @property
    def ego_ground(self) -> np.ndarray:
        """Ego-frame ground point ``(X forward, Y right)`` in metres of every pixel,
        shape (H, W, 2), measured from the vehicle's centre; NaN where the pixel sees
        no ground within range. Constant: the camera is fixed to the ego."""
        out = self._ego_ground.copy()
        out[~self.ground_valid] = np.nan
        return out


def _as_points(name: str, pts: np.ndarray) -> np.ndarray:
    """``pts`` as float64 (N, 2); one point (2,) becomes (1, 2). Non-finite points stay
    (they map to NaN: "no such point", as a ray that misses the ground)."""
    try:
        arr = np.asarray(pts, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"{name}: expected numbers of shape (N, 2), got {type(pts).__name__} {str(pts)[:60]!r}."
        ) from None
    if arr.ndim == 1 and arr.shape[0] == 2:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InvalidParameterError(f"{name}: expected an array of shape (N, 2), got shape {arr.shape}.")
    return arr
