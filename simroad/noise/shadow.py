"""Shadow: world-anchored cast shadows of roadside occluders and vehicles.

Physics
-------
A lit ground texel of albedo ρ has radiance ``ρ·(E_sun·cos θ + E_sky)``, a shadowed
one ``ρ·E_sky`` (θ the sun's zenith angle, so ``cos θ = sin e`` on flat ground). The
rendered frame is the lit scene, so a shadow scales linear radiance by
``k_c = 1 / (r_c·sin e + 1)`` per channel with ``r_c = E_sun/E_sky``. The clear sky is
blue, so ``r`` is smallest in blue: shadows keep relatively more blue — lower value,
higher saturation, higher blue/red ratio — which is the premise of the paper's NDI
shadow filter (eq. 13). Default ``r = (8, 6, 3)`` for (R, G, B), within the measured
3–9 of clear days. Fog dims the sun (``E_sun·exp(−τ/sin e)``) and with it the shadows.

Geometry
--------
Occluders (trees, poles, buildings, overpasses) are placed in world coordinates
beside the road, lazily per world cell with a seed derived from the episode seed and
the cell index (:mod:`simroad.noise._occluders`); vehicles and the ego cast box
shadows. Shadow polygons lie on the ground, so they are world-anchored: a shadow
stays where it is as the car drives over it. Each frame, the polygons near the view
are clipped to the half-plane ahead of the camera, projected with the camera's
ground homography, filled, and blurred by their penumbra (the sun's 0.53° disc seen
from the occluding edge), converted to pixels at the polygon's distance.
The occluders themselves are not drawn (the renderer has no roadside objects).

Sun direction convention: ``sun_azimuth_deg`` is the world heading of the sun's
horizontal direction (0 = world +x, 90 = world +y), like a vehicle heading.

Severity mapping (:meth:`ShadowParams.from_severity`), s in (0, 1]::

    occluders_per_100m = 20 · s                # trees 55 %, poles 30 %, buildings 15 %
    overpasses_per_km  = 2 · s
    sun_elevation_deg  = 60 − 40 · s           # lower sun, longer shadows
    sun_azimuth_deg    = 120                   # behind-right of a car heading world +x
    sun_sky_ratio_rgb  = (8, 6, 3)
    vehicle and ego shadows on

s = 0: no shadows at all (vehicle shadows off too).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np

from simroad._validation import SimroadError, check_in_range
from simroad.noise._geometry import SUN_AZIMUTH_LIMIT, draw_sun, ego_to_world, view_geometry
from simroad.noise._occluders import Occluders, RoadIndex, Shadows, place_cell, prism_shadows
from simroad.noise.context import FrameState
from simroad.noise.model import Limit, NoiseModel, Params

__all__ = ["ShadowModel", "ShadowParams", "rasterize_shadows", "shadow_factor"]

_NEAR_M = 0.5
_KERNELS = np.array([1, 3, 5, 9, 15])
_MAX_HEIGHT_M = 16.0
EGO_SIZE_M = (5.0, 2.0, 1.5)  # length, width, height of the ego's box


def shadow_factor(sun_sky_ratio_rgb, elevation_rad: float, sun_transmittance: float = 1.0) -> np.ndarray:
    """Per-channel ratio of shadowed to lit linear radiance, ``1/(r·t·sin e + 1)``."""
    r = np.asarray(sun_sky_ratio_rgb, dtype=float)
    return 1.0 / (r * sun_transmittance * math.sin(elevation_rad) + 1.0)


@dataclass(frozen=True)
class ShadowParams(Params):
    """Physical parameters of the sun and the shadow casters.

    Parameters
    ----------
    sun_azimuth_deg : float or None
        World heading towards the sun, degrees; ``None`` draws one per episode.
    sun_elevation_deg : float
        Sun elevation above the horizon, degrees.
    sun_sky_ratio_rgb : tuple of 3 float
        ``E_sun / E_sky`` per channel (R, G, B).
    occluders_per_100m : float
        Roadside trees, poles and buildings per 100 m of road.
    overpasses_per_km : float
        Overpasses per km of road.
    vehicle_shadows, ego_shadow : bool
        Shadows of the other vehicles and of the ego's own box.
    sun_diameter_deg : float
        Angular diameter of the sun, degrees (sets the penumbra).
    cell_m : float
        Side of the world cells occluders are placed in, m.

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "sun_azimuth_deg": SUN_AZIMUTH_LIMIT,
        "sun_elevation_deg": Limit(2.0, 89.0, "degrees"),
        "sun_sky_ratio_rgb": Limit(0.5, 50.0, length=3),
        "occluders_per_100m": Limit(0.0, 100.0),
        "overpasses_per_km": Limit(0.0, 20.0),
        "sun_diameter_deg": Limit(0.0, 5.0, "degrees"),
        "cell_m": Limit(10.0, 500.0, "m"),
    }

    sun_azimuth_deg: float | None = 120.0
    sun_elevation_deg: float = 35.0
    sun_sky_ratio_rgb: tuple[float, float, float] = (8.0, 6.0, 3.0)
    occluders_per_100m: float = 8.0
    overpasses_per_km: float = 0.0
    vehicle_shadows: bool = True
    ego_shadow: bool = True
    sun_diameter_deg: float = 0.53
    cell_m: float = 40.0

    @classmethod
    def from_severity(cls, severity: float) -> ShadowParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(
            sun_elevation_deg=60.0 - 40.0 * s,
            occluders_per_100m=20.0 * s,
            overpasses_per_km=2.0 * s,
            vehicle_shadows=s > 0,
            ego_shadow=s > 0,
        )

    @property
    def is_identity(self) -> bool:
        return (
            self.occluders_per_100m == 0.0
            and self.overpasses_per_km == 0.0
            and not self.vehicle_shadows
            and not self.ego_shadow
        )


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


def rasterize_shadows(shadows: Shadows, camera, *, near_m: float = _NEAR_M) -> np.ndarray:
    """Shadow coverage of every pixel, float32 (H, W) in [0, 1].

    Polygons are clipped to the ground half-plane at least ``near_m`` ahead of the
    camera, projected with ``camera.ground_to_image`` (its homography), filled with
    anti-aliased edges, and box-blurred by their penumbra in pixels (width
    ``w·f/d`` across, ``w·f·h/d²`` along the view at the polygon's distance d).
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
    kx, ky = _kernel(wx), _kernel(wx * cfg.mount_height_m / dist)
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
    """Cast shadows of roadside occluders and vehicles (see the module docstring)."""

    name = "shadow"
    params_type = ShadowParams
    stages = ("illumination",)

    def _on_reset(self) -> None:
        p = self.params
        self.sun = draw_sun(self._require_reset(), p.sun_azimuth_deg, p.sun_elevation_deg)
        w = self._world
        self._road = (
            RoadIndex(None)
            if w is None
            else RoadIndex(w.shapes, getattr(getattr(w, "palette", None), "shoulder_width_m", 1.0))
        )
        self._cells: OrderedDict[tuple[int, int], Shadows] = OrderedDict()
        self._coverage: np.ndarray | None = None
        self._gathered: tuple = (None, Shadows.empty())

    def set_sun(self, azimuth_rad: float, elevation_rad: float) -> None:
        """Use another model's sun (the weather shares one sun between models)."""
        self.sun = (float(azimuth_rad), float(elevation_rad))
        self._cells.clear()
        self._gathered = (None, Shadows.empty())

    def occluders(self, i: int, j: int) -> Occluders:
        """The occluders of world cell (i, j): a pure function of the episode seed and
        the cell index (not of the order cells are visited)."""
        p = self.params
        rng = np.random.default_rng([self._seed, i + 2**31, j + 2**31])
        box = (i * p.cell_m, j * p.cell_m, (i + 1) * p.cell_m, (j + 1) * p.cell_m)
        return place_cell(rng, box, self._road, per_100m=p.occluders_per_100m, overpass_per_km=p.overpasses_per_km)

    def cell(self, i: int, j: int) -> Shadows:
        """Shadows cast by the occluders of world cell (i, j) (cached)."""
        key = (i, j)
        hit = self._cells.get(key)
        if hit is not None:
            self._cells.move_to_end(key)
            return hit
        out = self.occluders(i, j).shadows(self.sun, math.radians(self.params.sun_diameter_deg))
        self._cells[key] = out
        if len(self._cells) > 4096:
            self._cells.popitem(last=False)
        return out

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

    def world_shadows(self, state: FrameState) -> Shadows:
        """All shadow polygons that may fall into the current view (world metres)."""
        p = self.params
        fp = np.column_stack(ego_to_world(view_geometry(state.camera).footprint, state.camera.pose))
        lo, hi = fp.min(axis=0), fp.max(axis=0)
        reach = min(100.0, _MAX_HEIGHT_M / math.tan(self.sun[1]))
        i0, j0 = np.floor((lo - reach) / p.cell_m).astype(int)
        i1, j1 = np.floor((hi + reach) / p.cell_m).astype(int)
        key = (i0, i1, j0, j1)
        if self._gathered[0] != key:
            cells = [self.cell(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]
            self._gathered = (key, Shadows.concat(cells))
        sh = Shadows.concat([self._gathered[1], self._vehicle_shadows(state)])
        b = sh.bbox
        return sh.select((b[:, 2] >= lo[0]) & (b[:, 0] <= hi[0]) & (b[:, 3] >= lo[1]) & (b[:, 1] <= hi[1]))

    def prepare(self, state: FrameState) -> None:
        cover = rasterize_shadows(self.world_shadows(state), state.camera)
        cover *= state.ground
        self._coverage = cover
        state.sun_visibility = 1.0 - cover

    def illumination(self, state: FrameState) -> None:
        cover = self._coverage
        if cover is None:
            raise SimroadError("ShadowModel.illumination() ran before prepare(); run the model through apply().")
        r = state.ground_rows
        t_sun = math.exp(-state.sun_optical_depth / math.sin(self.sun[1]))
        k = shadow_factor(self.params.sun_sky_ratio_rgb, self.sun[1], t_sun)
        c = cover[r]
        factor = cv2.merge([1.0 - c * np.float32(1.0 - kc) for kc in k])
        state.lin[r] *= factor
