"""The windscreen in front of the camera: its geometry, the optics of a drop on it, sprites.

Pure functions and per-camera constants for :mod:`simroad.noise.windscreen`.

Frames follow :mod:`simroad.noise._geometry`: ego X forward, Y right, Z down; camera x
right, y down, z forward. The glass is a plane fixed to the car, crossed by the
optical axis ``distance_m`` in front of the lens and tilted back from vertical by
``tilt_deg`` (its top leans towards the driver). Points on it have glass coordinates
``(gx, gy)`` in metres: ``gx`` to the right, ``gy`` up along the glass, origin where
the optical axis meets it.

A drop is a spherical cap of contact radius ``a`` and contact angle ``γ`` (Roser &
Geiger 2009): a thick plano-convex water lens. A camera ray crossing the glass at the
normalised radius ρ = r/a leaves the cap's curved surface, whose normal is tilted by
``β = asin(ρ·sin γ)``, at ``asin(n·sin β)``: it is deflected by
``D(ρ) = asin(n·ρ·sin γ) − asin(ρ·sin γ)`` towards (and past) the axis, so the drop shows
a small, inverted, wide-angle view of the scene around its own line of sight; beyond
``ρ = 1/(n·sin γ)`` the ray is totally reflected and the rim shows the dark inside of
the car (:func:`cap_deflection`, :func:`cap_transmittance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.core.constants import WATER_N
from simroad.noise._geometry import fresnel_unpolarized, view_geometry

__all__ = [
    "MIN_ALPHA",
    "UNIFORM_BELOW_PX",
    "Glass",
    "GlassView",
    "Sprite",
    "cap_deflection",
    "cap_transmittance",
    "contact_radius",
    "defocus_diameter_m",
    "drop_sprite",
    "glass_view",
]

#: Drops whose image half-width is below this (px) are drawn in one colour: their mean view.
UNIFORM_BELOW_PX = 2.5
#: Sprite pixels the drop covers less than this (a fiftieth of the aperture) are left out.
MIN_ALPHA = 0.02
_MAX_RANGE_M = 2.0  # rays that graze the glass: seen this far along the ray at most


def contact_radius(diameter_m: np.ndarray | float, contact_angle_deg: float) -> np.ndarray:
    """Contact radius ``a`` (m) of a sessile spherical cap with the volume of a sphere.

    ``π·D³/6 = π·a³·(2 − 3cos γ + cos³ γ)/(3·sin³ γ)`` solved for ``a``.

    Parameters
    ----------
    diameter_m : array_like
        Diameter of the free drop (volume-equivalent sphere), m.
    contact_angle_deg : float
        Contact angle γ of water on the glass, degrees in (0, 180).
    """
    g = math.radians(contact_angle_deg)
    c, s = math.cos(g), math.sin(g)
    k = (4.0 * s**3 / (2.0 - 3.0 * c + c**3)) ** (1.0 / 3.0)
    return 0.5 * k * np.asarray(diameter_m, dtype=float)


def cap_deflection(rho: np.ndarray, contact_angle_deg: float, n: float = WATER_N) -> np.ndarray:
    """Deflection ``D(ρ)`` in radians of a ray leaving a drop at normalised radius ρ.

    ``D = asin(n·ρ·sin γ) − asin(ρ·sin γ)`` for a ray along the drop's axis; NaN where
    the ray is totally reflected (``n·ρ·sin γ > 1``).
    """
    s = np.asarray(rho, dtype=float) * math.sin(math.radians(contact_angle_deg))
    inner = n * s
    with np.errstate(invalid="ignore"):
        return np.where(inner <= 1.0, np.arcsin(np.minimum(inner, 1.0)) - np.arcsin(np.minimum(s, 1.0)), np.nan)


def cap_transmittance(rho: np.ndarray, contact_angle_deg: float, n: float = WATER_N) -> np.ndarray:
    """Fraction of radiance a ray keeps leaving the drop's curved surface (water to air).

    Unpolarised Fresnel transmittance at the exit angle (by reciprocity, the air-side
    reflectance at ``asin(n·sin β)``); 0 under total internal reflection and outside
    the drop (ρ > 1).
    """
    rho = np.asarray(rho, dtype=float)
    s = np.minimum(rho, 1.0) * math.sin(math.radians(contact_angle_deg))
    inner = n * s
    cos_air = np.sqrt(np.maximum(1.0 - inner * inner, 0.0))
    t = 1.0 - fresnel_unpolarized(cos_air, n)
    return np.where((inner < 1.0) & (rho <= 1.0), t, 0.0)


def defocus_diameter_m(focal_length_m: float, aperture_m: float, object_m: float, focus_m: float) -> float:
    """Diameter of the blur circle on the sensor (m) of a point at ``object_m`` (thin lens).

    A lens of focal length f and aperture (entrance pupil) A focused at S images a
    point at distance z as a disc of diameter ``c = A·f·|S − z| / (z·(S − f))``;
    ``focus_m = inf`` gives ``A·f/(z − f)``. Divide by the pixel pitch
    (``f / fx``) for pixels: ``c_px = fx·A·|S − z| / (z·(S − f))``.
    """
    f, a, z = float(focal_length_m), float(aperture_m), float(object_m)
    if math.isinf(focus_m):
        return a * f / (z - f)
    s = float(focus_m)
    return a * f * abs(s - z) / (z * (s - f))


@dataclass(frozen=True)
class Glass:
    """The windscreen and the lens behind it (all lengths in m, angles in degrees)."""

    distance_m: float
    tilt_deg: float
    focal_length_m: float
    aperture_m: float
    focus_m: float


@dataclass(frozen=True, eq=False)
class GlassView:
    """Per-pixel constants of one camera behind one glass (arrays float32 (H, W)).

    Attributes
    ----------
    fx : float
        Focal length in pixels.
    dist : ndarray
        Distance from the lens to the glass along each pixel's ray, m.
    cos_inc : ndarray
        Cosine of the angle between the ray and the glass normal.
    gx, gy : ndarray
        Glass coordinates of the point each pixel sees, m.
    area : ndarray
        Glass area each pixel sees, m².
    blur : ndarray
        Defocus blur diameter of the glass at each pixel, px.
    area_cdf : ndarray float64 (H·W,)
        Cumulative ``area`` over the flattened image (for uniform sampling on the glass).
    """

    config: CameraConfig
    glass: Glass
    fx: float
    dist: np.ndarray
    cos_inc: np.ndarray
    gx: np.ndarray
    gy: np.ndarray
    area: np.ndarray
    blur: np.ndarray
    area_cdf: np.ndarray
    _R: np.ndarray
    _K: np.ndarray
    _K_inv: np.ndarray
    _normal: np.ndarray
    _origin: np.ndarray
    _up: np.ndarray

    @property
    def view_area_m2(self) -> float:
        """Glass area in view, m²."""
        return float(self.area_cdf[-1])

    def pixel_to_glass(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Glass coordinates ``(gx, gy)`` (m) and distance (m) of image points ``(u, v)``."""
        uv1 = np.stack([np.asarray(u, float), np.asarray(v, float), np.ones(np.shape(u))])
        rays = self._R.T @ (self._K_inv @ uv1)  # ego frame, (3, N)
        nr = self._normal @ rays
        t = np.where(nr > 1e-9, (self._normal @ self._origin) / np.maximum(nr, 1e-9), np.inf)
        t = np.minimum(t, _MAX_RANGE_M / np.linalg.norm(rays, axis=0))
        p = rays * t - self._origin[:, None]
        return p[1], self._up @ p, t * np.linalg.norm(rays, axis=0)

    def projection(self) -> np.ndarray:
        """(3, 3) float64: the homogeneous image point of the glass origin, and its
        change per metre along the glass's ``gx`` and ``gy`` (columns), as
        :meth:`glass_to_pixel` maps them."""
        m = self._K @ self._R
        return np.stack([m @ self._origin, m @ np.array([0.0, 1.0, 0.0]), m @ self._up], axis=1)

    def glass_to_pixel(self, gx: np.ndarray, gy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image points ``(u, v)`` (px) of glass points ``(gx, gy)`` (m)."""
        gx, gy = np.asarray(gx, float), np.asarray(gy, float)
        pts = self._origin[:, None] + np.outer([0.0, 1.0, 0.0], gx) + np.outer(self._up, gy)
        cam = self._K @ (self._R @ pts)
        return cam[0] / cam[2], cam[1] / cam[2]


@lru_cache(maxsize=16)
def _glass_view(config: CameraConfig, glass: Glass) -> GlassView:
    geom = view_geometry(PinholeCamera(config))
    phi = math.radians(glass.tilt_deg)
    normal = np.array([math.cos(phi), 0.0, -math.sin(phi)])  # forward and up (Z is down)
    up = np.array([-math.sin(phi), 0.0, -math.cos(phi)])  # up the glass, leaning back
    origin = glass.distance_m * geom.R_ego[2]  # where the optical axis meets the glass
    rx, ry, rz = (p.astype(np.float64) for p in geom.ray_planes)  # unit rays, ego frame
    nr = normal[0] * rx + normal[2] * rz
    t = np.where(nr > 1e-6, (normal @ origin) / np.maximum(nr, 1e-6), np.inf)
    t = np.minimum(t, _MAX_RANGE_M)
    px, py, pz = rx * t - origin[0], ry * t - origin[1], rz * t - origin[2]
    cos_inc = np.clip(nr, 1e-3, 1.0)
    cos_axis = rx * geom.R_ego[2, 0] + rz * geom.R_ego[2, 2]  # cosine to the optical axis
    area = t * t * cos_axis**3 / (geom.fx * geom.fx) / cos_inc
    z = t * cos_axis  # depth along the optical axis
    c_m = (
        glass.aperture_m
        * glass.focal_length_m
        * np.abs(glass.focus_m - z)
        / (z * (glass.focus_m - glass.focal_length_m))
    )
    blur = c_m * geom.fx / glass.focal_length_m
    f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32)  # noqa: E731
    K = np.array([[geom.fx, 0.0, geom.cx], [0.0, geom.fy, geom.cy], [0.0, 0.0, 1.0]])
    return GlassView(
        config=config,
        glass=glass,
        fx=float(geom.fx),
        dist=f32(t),
        cos_inc=f32(cos_inc),
        gx=f32(py),
        gy=f32(up @ np.stack([px, py, pz]).reshape(3, -1)).reshape(t.shape),
        area=f32(area),
        blur=f32(blur),
        area_cdf=np.cumsum(area.ravel()),
        _R=geom.R_ego,
        _K=K,
        _K_inv=np.linalg.inv(K),
        _normal=normal,
        _origin=origin,
        _up=up,
    )


def glass_view(camera: PinholeCamera, glass: Glass) -> GlassView:
    """The cached :class:`GlassView` of a camera's mounting behind ``glass``."""
    return _glass_view(camera.config, glass)


@dataclass(frozen=True, eq=False)
class Sprite:
    """The footprint of one drop on the image, relative to its centre pixel.

    Every array has one entry per pixel the drop touches: ``du, dv`` (int32) the pixel
    offsets; ``alpha`` the fraction of the lens aperture the drop covers for that
    pixel (its defocused coverage); ``w_scene`` the part of it that carries the
    refracted scene (``alpha − w_scene`` is lost to total internal reflection and
    Fresnel reflection at the rim); ``src_du, src_dv`` (float32) where, relative to the
    drop's centre, that refracted scene comes from, in px. A ``uniform`` sprite (a
    drop less than :data:`UNIFORM_BELOW_PX` wide) is drawn in one colour, its whole
    view averaged: its source offsets are zero.
    """

    uniform: bool
    du: np.ndarray
    dv: np.ndarray
    alpha: np.ndarray
    w_scene: np.ndarray
    src_du: np.ndarray
    src_dv: np.ndarray


def _disc_kernel(diameter_px: float) -> np.ndarray:
    """A normalised pillbox of ``diameter_px`` (anti-aliased; a delta below 1 px)."""
    if diameter_px < 1.0:
        return np.ones((1, 1), np.float32)
    h = int(math.ceil(diameter_px / 2.0))
    ss = 8
    x = (np.arange((2 * h + 1) * ss) + 0.5) / ss - (h + 0.5)
    inside = (x[None, :] ** 2 + x[:, None] ** 2) <= (diameter_px / 2.0) ** 2
    k = inside.reshape(2 * h + 1, ss, 2 * h + 1, ss).mean(axis=(1, 3)).astype(np.float32)
    return k / k.sum()


def drop_sprite(rx: float, ry: float, blur_px: float, fx: float, contact_angle_deg: float) -> Sprite:
    """The defocused image of a drop of image half-axes ``rx, ry`` (px).

    The in-focus drop (an ellipse: the cap foreshortened by the glass's tilt, 4×4
    supersampled) carries, per point, its transmittance and the direction its ray
    leaves in (:func:`cap_deflection`, in pixels ``fx·tan D`` from the drop's centre,
    inverted); the camera, focused far away, sees it blurred by a pillbox of
    ``blur_px``: coverage, transmittance and source offsets are blurred together
    (the source offsets weighted by what they carry).
    """
    ss = 4
    hx = int(math.ceil(rx + blur_px / 2.0)) + 1
    hy = int(math.ceil(ry + blur_px / 2.0)) + 1
    x = (np.arange((2 * hx + 1) * ss) + 0.5) / ss - (hx + 0.5)
    y = (np.arange((2 * hy + 1) * ss) + 0.5) / ss - (hy + 0.5)
    px, py = np.meshgrid(x / rx, y / ry)
    rho = np.hypot(px, py)
    inside = (rho <= 1.0).astype(float)
    trans = cap_transmittance(rho, contact_angle_deg)
    defl = np.nan_to_num(cap_deflection(np.minimum(rho, 1.0), contact_angle_deg))
    k = -fx * np.tan(defl) / np.maximum(rho, 1e-9)  # inverted: towards the other side
    fields = np.stack([inside, trans, trans * k * px, trans * k * py], axis=-1)
    fields = fields.reshape(2 * hy + 1, ss, 2 * hx + 1, ss, 4).mean(axis=(1, 3)).astype(np.float32)
    fields = cv2.filter2D(fields, -1, _disc_kernel(blur_px), borderType=cv2.BORDER_CONSTANT)
    alpha, w_scene = fields[..., 0], fields[..., 1]
    keep = alpha >= MIN_ALPHA
    dv, du = np.nonzero(keep)
    w = np.maximum(w_scene[keep], 1e-9)
    uniform = rx < UNIFORM_BELOW_PX
    if uniform:
        fields[..., 2:] = 0.0
    return Sprite(
        uniform=bool(uniform),
        du=(du - hx).astype(np.int32),
        dv=(dv - hy).astype(np.int32),
        alpha=np.minimum(alpha[keep], 1.0),
        w_scene=np.minimum(w_scene[keep], alpha[keep]),
        src_du=(fields[..., 2][keep] / w).astype(np.float32),
        src_dv=(fields[..., 3][keep] / w).astype(np.float32),
    )
