"""Shadow: the sun comes out and every solid of the world casts its shadow.

Physics
-------
Clear weather is a bright overcast day (:mod:`simroad.camera.lighting`); this model
brings out the sun. A lit ground texel of albedo ρ has radiance
``ρ·(E_sun·cos θ + E_sky)``, a shadowed one ``ρ·E_sky`` (θ the sun's zenith angle, so
``cos θ = sin e`` on flat ground). The rendered frame stands for the lit scene, so a
shadow scales linear radiance by ``k_c = 1 / (r_c·sin e + 1)`` per channel with
``r_c = E_sun/E_sky``. The clear sky is blue, so ``r`` is smallest in blue: shadows
keep relatively more blue — lower value, higher saturation, higher blue/red ratio —
which is the premise of the paper's NDI shadow filter (eq. 13). Fog dims the sun
(``E_sun·exp(−τ/sin e)``) and with it the shadows.

Faces of objects (when the frame carries ``face_id`` and ``faces``): a face lit
under the overcast sky has ``ρ·E_sky·F(n)`` with ``F`` the sky-view irradiance
factor (:func:`simroad.camera.lighting.face_irradiance`); in the sun it gets
``ρ·(E_sun·max(0, n·ŝ) + E_sky·F(n))``. Normalised like the ground (the frame is the
lit horizontal scene), a face pixel is scaled by
``(r_c·max(0, n·ŝ)/F(n) + 1) / (r_c·sin e + 1)``: a face turned away from the sun
(``n·ŝ <= 0``) is in its own shadow and darkened by exactly the ground's ``k_c``; a
face turned towards a low sun brightens (a sunlit wall is brighter than the road).

The sky: with the sun out the sky clears, towards the CIE clear sky of the same sun
(:mod:`simroad.noise._sunny_sky`), in proportion to ``mean(r) / 5`` (fully clear
from E_sun/E_sky = 5 on). The sky's change is a change of weather, not noise: it is
left out of the noise mask.

Geometry
--------
Casters are the world's solids (``world.objects(box)``: trees, poles, signs,
buildings, walls, guard rails, overpasses; :mod:`simroad.camera.scenery`), the other
vehicles' boxes and the ego's. The shadow of a convex solid is the hull of its
vertices projected along the sun onto the ground (:mod:`simroad.noise._occluders`),
so every shadow has its caster in the world. Shadows lie on the ground, so they are
world-anchored. Each frame, the polygons near the view are clipped to the
half-plane ahead of the camera, projected with the camera's ground homography,
filled, and blurred by their penumbra (the sun's 0.53° disc seen from the caster's
top), converted to pixels at the polygon's distance. Without a world (or a world
without scenery, e.g. the gallery scene) only vehicles and the ego cast shadows.

Limitation: shadows fall on the ground only, not on other objects (a tree's shadow
does not darken a wall behind it); an object's own faces are shaded by their
orientation to the sun only.

Sun direction convention: ``sun_azimuth_deg`` is the world heading of the sun's
horizontal direction (0 = world +x, 90 = world +y), like a vehicle heading.

Severity mapping (:meth:`ShadowParams.from_severity`), s in [0, 1] — severity sets
the sun, the casters are whatever the world holds::

    sun_elevation_deg  = 60 − 40 · s           # lower sun, longer shadows
    sun_sky_ratio_rgb  = s · (8, 6, 3)         # stronger sun: ~1 at s = 0.15, (8, 6, 3) at 1
    sun_azimuth_deg    = 120                   # behind-right of a car heading world +x
    vehicle and ego shadows on

s = 0: no sun (``r = 0``), the frame is unchanged. ``r = (8, 6, 3)`` lies within the
measured 3–9 of clear days. The former ``occluders_per_100m``, ``overpasses_per_km``
and ``cell_m`` are gone: how much stands beside the road is the world's
(``RoadCamConfig.scenery``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np

from simroad.camera.lighting import face_irradiance
from simroad.core.validation import check_in_range
from simroad.errors import InvalidParameterError
from simroad.noise._geometry import SUN_AZIMUTH_LIMIT, draw_sun, ego_to_world, view_geometry
from simroad.noise._occluders import Shadows, mesh_shadows, prism_shadows
from simroad.noise._sunny_sky import CLEAR_SKY_RATIO, clear_sky
from simroad.noise.context import FrameState
from simroad.noise.model import Limit, NoiseModel, Params

__all__ = ["FULL_SUN_SKY_RATIO", "ShadowModel", "ShadowParams", "face_sun_factor", "rasterize_shadows", "shadow_factor"]

_NEAR_M = 0.5
_KERNELS = np.array([1, 3, 5, 9, 15])
_MAX_HEIGHT_M = 25.0  # tallest caster considered (m): how far a shadow may reach
_GATHER_M = 50.0  # the casters are gathered for a box snapped to this grid, m
#: ``E_sun / E_sky`` (R, G, B) of severity 1: a clear day's sun.
FULL_SUN_SKY_RATIO = (8.0, 6.0, 3.0)
EGO_SIZE_M = (5.0, 2.0, 1.5)  # length, width, height of the ego's box


def shadow_factor(sun_sky_ratio_rgb, elevation_rad: float, sun_transmittance: float = 1.0) -> np.ndarray:
    """Per-channel ratio of shadowed to lit linear radiance, ``1/(r·t·sin e + 1)``."""
    r = np.asarray(sun_sky_ratio_rgb, dtype=float)
    return 1.0 / (r * sun_transmittance * math.sin(elevation_rad) + 1.0)


def face_sun_factor(
    normals: np.ndarray, sun: tuple[float, float], sun_sky_ratio_rgb, sun_transmittance: float = 1.0
) -> np.ndarray:
    """Per-face, per-channel factor on the rendered (overcast-lit) radiance, (F, 3)
    float32: ``(r·t·max(0, n·ŝ)/F(n) + 1) / (r·t·sin e + 1)`` (module docstring);
    ``normals`` (F, 3) world unit normals, ``sun = (azimuth, elevation)`` in rad."""
    az, el = sun
    s = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    cos_i = np.maximum(n @ s, 0.0)
    sky = face_irradiance(n[:, 2]).astype(float)
    r = np.asarray(sun_sky_ratio_rgb, dtype=float) * sun_transmittance
    return ((r[None, :] * (cos_i / sky)[:, None] + 1.0) / (r * math.sin(el) + 1.0)).astype(np.float32)


@dataclass(frozen=True)
class ShadowParams(Params):
    """Physical parameters of the sun (the casters are the world's objects).

    Parameters
    ----------
    sun_azimuth_deg : float or None
        World heading towards the sun, degrees; ``None`` draws one per episode.
    sun_elevation_deg : float
        Sun elevation above the horizon, degrees.
    sun_sky_ratio_rgb : tuple of 3 float
        ``E_sun / E_sky`` per channel (R, G, B); ``(0, 0, 0)`` is no sun (the
        identity), :data:`FULL_SUN_SKY_RATIO` a clear day's.
    vehicle_shadows, ego_shadow : bool
        Shadows of the other vehicles and of the ego's own box.
    sun_diameter_deg : float
        Angular diameter of the sun, degrees (sets the penumbra).

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "sun_azimuth_deg": SUN_AZIMUTH_LIMIT,
        "sun_elevation_deg": Limit(2.0, 89.0, "degrees"),
        "sun_sky_ratio_rgb": Limit(0.0, 50.0, length=3),
        "sun_diameter_deg": Limit(0.0, 5.0, "degrees"),
    }

    sun_azimuth_deg: float | None = 120.0
    sun_elevation_deg: float = 35.0
    sun_sky_ratio_rgb: tuple[float, float, float] = FULL_SUN_SKY_RATIO
    vehicle_shadows: bool = True
    ego_shadow: bool = True
    sun_diameter_deg: float = 0.53

    @classmethod
    def from_severity(cls, severity: float) -> ShadowParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        r = tuple(s * c for c in FULL_SUN_SKY_RATIO)
        return cls(sun_elevation_deg=60.0 - 40.0 * s, sun_sky_ratio_rgb=(r[0], r[1], r[2]))

    @property
    def is_identity(self) -> bool:
        return all(c == 0.0 for c in self.sun_sky_ratio_rgb)


def _kernel(px: np.ndarray) -> np.ndarray:
    """Smallest odd box width from ``_KERNELS`` covering ``px`` pixels."""
    i = np.searchsorted(_KERNELS, np.maximum(px, 1.0))
    return _KERNELS[np.minimum(i, len(_KERNELS) - 1)]


def _clip_halfplane(poly: np.ndarray, signed: np.ndarray, near: float) -> np.ndarray:
    """Sutherland–Hodgman clip of a polygon to ``signed >= near``."""
    out = []
    n = len(poly)
    for k in range(n):
        p, q, sp, sq = poly[k], poly[(k + 1) % n], signed[k], signed[(k + 1) % n]
        if sp >= near:
            out.append(p)
        if (sp >= near) != (sq >= near):
            out.append(p + (near - sp) / (sq - sp) * (q - p))
    return np.array(out)


def rasterize_shadows(shadows: Shadows, camera, *, near_m: float = _NEAR_M, motion_m: float = 0.0) -> np.ndarray:
    """Shadow coverage of every pixel, float32 (H, W) in [0, 1].

    Polygons are clipped to the ground half-plane at least ``near_m`` ahead of the
    camera, projected with ``camera.ground_to_image`` (its homography), filled with
    anti-aliased edges, and box-blurred by their penumbra in pixels (width
    ``w·f/d`` across, ``w·f·h/d²`` along the view at the polygon's distance d); the
    camera's travel during the exposure ``motion_m`` widens the box along the view by
    ``motion_m·f·h/d²`` (the ground's motion blur).
    """
    cfg = camera.config
    H, W = cfg.height, cfg.width
    if len(shadows.penumbra_m) == 0:
        return np.zeros((H, W), dtype=np.float32)
    c = camera.position_world
    hd = camera.pose[2]
    signed = (shadows.polys - c) @ np.array([math.cos(hd), math.sin(hd)])
    lo, hi = signed.min(axis=1), signed.max(axis=1)
    whole = np.flatnonzero(lo >= near_m)
    polys = list(shadows.polys[whole])
    keep = list(whole)
    for k in np.flatnonzero((lo < near_m) & (hi >= near_m)):
        poly = _clip_halfplane(shadows.polys[k], signed[k], near_m)
        if len(poly) >= 3:
            polys.append(poly)
            keep.append(k)
    if not polys:
        return np.zeros((H, W), dtype=np.float32)
    kept = np.asarray(keep)
    sizes = np.array([len(p) for p in polys])
    uv = camera.ground_to_image(np.concatenate(polys))
    b = shadows.bbox[kept]
    centre = 0.5 * (b[:, :2] + b[:, 2:])
    dist = np.maximum(np.hypot(*(centre - c).T), 2.0)
    wx = shadows.penumbra_m[kept] * camera.K[0, 0] / dist
    # Along the view the ground also slides by the exposure's travel: its box adds
    # to the penumbra's (the motion blur of the ground, as the renderer's).
    along = (shadows.penumbra_m[kept] + motion_m) * camera.K[0, 0] / dist
    kx, ky = _kernel(wx), _kernel(along * cfg.mount_height_m / dist)
    pts = np.round(np.clip(uv, -1e5, 1e5) * 16).astype(np.int32)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    out = np.zeros((H, W), dtype=np.uint8)
    for key in sorted(set(zip(kx.tolist(), ky.tolist()))):
        canvas = np.zeros((H, W), dtype=np.uint8)
        for k in np.flatnonzero((kx == key[0]) & (ky == key[1])):
            cv2.fillConvexPoly(canvas, pts[starts[k] : starts[k] + sizes[k]], 255, cv2.LINE_AA, 4)
        if key != (1, 1):
            canvas = cv2.blur(canvas, key)
        cv2.max(out, canvas, dst=out)
    return out.astype(np.float32) * np.float32(1.0 / 255.0)


class ShadowModel(NoiseModel):
    """The sun and the cast shadows of the world's objects and the vehicles (see the
    module docstring)."""

    name = "shadow"
    params_type = ShadowParams
    stages = ("illumination",)

    def _on_reset(self) -> None:
        p = self.params
        self.sun = draw_sun(self._require_reset(), p.sun_azimuth_deg, p.sun_elevation_deg)
        self._coverage: np.ndarray | None = None
        self._gathered: tuple = (None, Shadows.empty())

    def set_sun(self, azimuth_rad: float, elevation_rad: float) -> None:
        """Use another model's sun (the weather shares one sun between models)."""
        self.sun = (float(azimuth_rad), float(elevation_rad))
        self._gathered = (None, Shadows.empty())

    def _vehicle_shadows(self, state: FrameState) -> Shadows:
        p = self.params
        boxes = []
        if p.vehicle_shadows:
            boxes += [(v.corners(), v.height) for v in state.ctx.vehicles]
        if p.ego_shadow:
            x, y, h = state.camera.pose
            l, w, ht = EGO_SIZE_M
            c, s = math.cos(h), math.sin(h)
            f, r = np.array([c, s]) * l / 2, np.array([-s, c]) * w / 2
            ctr = np.array([x, y])
            boxes.append((np.array([ctr + f - r, ctr + f + r, ctr - f + r, ctr - f - r]), ht))
        if not boxes:
            return Shadows.empty()
        z1 = np.array([b[1] for b in boxes])
        return prism_shadows(
            [b[0] for b in boxes], np.zeros(len(boxes)), z1, self.sun, math.radians(p.sun_diameter_deg)
        )

    def caster_box(self, state: FrameState) -> tuple[float, float, float, float]:
        """The world box (m) whose objects may shadow the view: the view's ground
        footprint grown by the longest shadow, snapped outwards to a 50 m grid."""
        fp = np.column_stack(ego_to_world(view_geometry(state.camera).footprint, state.camera.pose))
        reach = min(100.0, _MAX_HEIGHT_M / math.tan(self.sun[1]))
        lo = np.floor((fp.min(axis=0) - reach) / _GATHER_M) * _GATHER_M
        hi = np.ceil((fp.max(axis=0) + reach) / _GATHER_M) * _GATHER_M
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    def world_shadows(self, state: FrameState) -> Shadows:
        """All shadow polygons that may fall into the current view (world metres);
        ``caster`` indexes the solids of ``world.objects(*caster_box(state))``."""
        box = self.caster_box(state)
        if self._gathered[0] != box:
            objects = getattr(self._world, "objects", None)
            mesh = objects(*box) if objects is not None else None
            cast = (
                Shadows.empty()
                if mesh is None
                else mesh_shadows(mesh, self.sun, math.radians(self.params.sun_diameter_deg))
            )
            self._gathered = (box, cast)
        sh = Shadows.concat([self._gathered[1], self._vehicle_shadows(state)])
        fp = np.column_stack(ego_to_world(view_geometry(state.camera).footprint, state.camera.pose))
        lo, hi = fp.min(axis=0), fp.max(axis=0)
        b = sh.bbox
        return sh.select((b[:, 2] >= lo[0]) & (b[:, 0] <= hi[0]) & (b[:, 3] >= lo[1]) & (b[:, 1] <= hi[1]))

    def prepare(self, state: FrameState) -> None:
        cover = rasterize_shadows(self.world_shadows(state), state.camera, motion_m=state.ctx.motion_m)
        cover *= state.ground
        self._coverage = cover
        state.sun_visibility = 1.0 - cover

    def illumination(self, state: FrameState) -> None:
        cover = self._coverage
        if cover is None:
            raise InvalidParameterError(
                "ShadowModel.illumination() ran before prepare(); run the model through apply()."
            )
        r = state.ground_rows
        t_sun = math.exp(-state.sun_optical_depth / math.sin(self.sun[1]))
        # The sun is out: the sky clears with it (full at today's clear-day ratio).
        clear_sky(state, self.sun, t_sun * float(np.mean(self.params.sun_sky_ratio_rgb)) / CLEAR_SKY_RATIO)
        k = shadow_factor(self.params.sun_sky_ratio_rgb, self.sun[1], t_sun)
        c = cover[r]
        if c.size:  # no ground in view (a wall or a truck fills the frame): nothing is shadowed
            factor = cv2.merge([1.0 - c * np.float32(1.0 - kc) for kc in k])
            state.lin[r] *= factor
        ctx = state.ctx
        if ctx.face_id is not None and ctx.faces is not None and len(ctx.faces):
            fid = ctx.face_id
            on = fid >= 0
            if on.any():
                per_face = face_sun_factor(ctx.faces.normal, self.sun, self.params.sun_sky_ratio_rgb, t_sun)
                state.lin[on] *= per_face[fid[on]]
