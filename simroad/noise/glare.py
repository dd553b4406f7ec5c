"""Glare: the sun's specular lobe on the road (paper eq. 23), veiling glare, bloom.

Physics
-------
* **Dichromatic reflection** (eq. 23): ``I = w_d·B + w_s·G``. The rendered frame is
  the diffuse term ``w_d·B``; this model adds the specular term, with G the sun's
  colour and ``w_s`` a Cook–Torrance microfacet lobe of the sun on the flat ground
  seen along each pixel's own view ray (Beckmann distribution of rms slope m,
  Schlick's Fresnel, Smith–Schlick shadowing):
  ``L_s = E_sun·F·D·G / (4·cos θ_v)``. In the frame's units (``NOMINAL_EXPOSURE`` =
  a white Lambertian surface under the scene's illumination E_ref = E_sun·sin e +
  E_sky, :mod:`simroad.camera.lighting`) this is
  ``NOMINAL_EXPOSURE·π·(E_sun/E_ref)·F·D·G/(4·cos θ_v)``. Dry asphalt is rough (m = 0.35, F0 = 0.04);
  the ``wetness`` fraction is under a smooth water film (m = 0.06, F0 = 0.02) that
  mirrors the sun (rain's ``water_film`` adds to it when composed).
  The lobe peaks where the view ray meets the ground at the sun's elevation, so a low
  sun ahead lights the road in front of the car; it depends on the camera heading
  against the sun's azimuth and moves as the car turns.
* **Sun colour** — Rayleigh extinction along the air mass m (Kasten & Young 1989):
  ``exp(−τ_c·m)`` with τ = (0.05, 0.10, 0.23) for (R, G, B), normalised to its
  maximum: white at noon, orange near the horizon.
* **Veiling glare** — light scattered in the lens (and windscreen) veils the whole
  frame by ``L_v = k·E_glare/θ²`` (Stiles & Holladay; θ in degrees between a pixel's
  ray and the sun, E_glare the sun's irradiance on the lens, k = 10 for the human
  eye), i.e. ``π·k·(E_sun/E_ref)·cos(α)/(θ² + θ0²)`` in frame units (α the sun's
  angle off the optical axis, θ0 = 1° for the core).
* **Bloom and saturation** — the sun's disc saturates the sensor and bleeds into
  its neighbours: ``gain·exp(−θ²/θ_b²)``; everything above 1.0 clips to 255.
  Bloom needs the sun in front of the lens and not hidden by a vehicle.

Severity mapping (:meth:`GlareParams.from_severity`), s in (0, 1]::

    sun_elevation_deg = 21 − 16 · s          # in view from s ≈ 0.3 (the frame's top edge is
                                             # ~16° up), 5° above the horizon at s = 1
    sun_azimuth_deg   = 0                    # world +x: ahead on highway-env's straights
    wetness           = 0.5 · s              # water film on the road after a shower
    veil_coeff        = 0.5 + 2.5 · s        # clean lens … dirty windscreen
    sun_sky_ratio     = 6 (E_sun/E_sky), roughness 0.35, bloom 1.5°

s = 0 is an overcast sky (``sun_sky_ratio = 0``): no glare. With the sun out the sky
clears towards the CIE clear sky of the same sun, as under the shadow model
(:mod:`simroad.noise._sunny_sky`; left out of the noise mask).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np

from simroad.camera.codes import ASPHALT, MARKING, ROADSIDE, SHOULDER, SKY
from simroad.camera.lighting import NOMINAL_EXPOSURE
from simroad.core.validation import check_in_range
from simroad.noise._arrays import fast_exp, material_weights
from simroad.noise._geometry import SUN_AZIMUTH_LIMIT, draw_sun, sun_direction_ego, view_geometry
from simroad.noise._sunny_sky import CLEAR_SKY_RATIO, clear_sky
from simroad.noise.context import FrameState
from simroad.noise.model import Limit, NoiseModel, Params

__all__ = ["GlareModel", "GlareParams", "air_mass", "specular_lobe", "sun_colour", "veiling_glare"]

RAYLEIGH_TAU_RGB = np.array([0.05, 0.10, 0.23])
WATER_ROUGHNESS = 0.06
_SPEC = {ASPHALT: 1.0, MARKING: 1.0, SHOULDER: 0.5, ROADSIDE: 0.1}
_THETA0_DEG2 = 1.0
_DEG2 = (180.0 / math.pi) ** 2


def air_mass(elevation_rad: float) -> float:
    """Relative optical air mass (Kasten & Young 1989) at a solar elevation."""
    e = math.degrees(elevation_rad)
    return 1.0 / (math.sin(elevation_rad) + 0.50572 * (e + 6.07995) ** -1.6364)


def sun_colour(elevation_rad: float) -> np.ndarray:
    """Relative RGB of direct sunlight after Rayleigh extinction, max channel 1."""
    c = np.exp(-RAYLEIGH_TAU_RGB * air_mass(elevation_rad))
    return (c / c.max()).astype(np.float32)


def specular_lobe(rx, ry, rz, sun: np.ndarray, roughness: float, f0: float) -> np.ndarray:
    """Cook–Torrance ``F·D·G/(4·cos θ_v)`` of the sun on flat ground, per pixel.

    Parameters
    ----------
    rx, ry, rz : ndarray float32
        Unit view rays of ground pixels in the ego frame (X forward, Y right, Z down).
    sun : ndarray (3,)
        Unit vector towards the sun in the ego frame.
    roughness : float
        Beckmann rms slope m.
    f0 : float
        Fresnel reflectance at normal incidence.

    Returns
    -------
    ndarray float32, same shape as ``rx`` (1/sr: multiply by E_sun for radiance).
    """
    s0, s1, s2 = (np.float32(v) for v in sun)
    hx, hy, hz = s0 - rx, s1 - ry, s2 - rz  # s + v with v = -ray
    hn = cv2.sqrt(hx * hx + hy * hy + hz * hz)
    ndh = np.maximum(-hz / hn, np.float32(1e-4))  # n = (0, 0, -1)
    vdh = np.clip((np.float32(1.0) - (rx * s0 + ry * s1 + rz * s2)) / hn, 0.0, 1.0)
    ndv = np.maximum(rz, np.float32(1e-4))
    ndl = max(-float(s2), 1e-4)
    m2 = np.float32(roughness * roughness)
    c2 = ndh * ndh
    d = fast_exp((c2 - 1.0) / (c2 * m2)) / (np.float32(math.pi) * m2 * c2 * c2)
    f = np.float32(f0) + np.float32(1.0 - f0) * (1.0 - vdh) ** 5
    k = np.float32(roughness * math.sqrt(2.0 / math.pi))
    g = (ndl / (ndl * (1.0 - k) + k)) * (ndv / (ndv * (1.0 - k) + k))
    return (f * d * g / (4.0 * ndv)).astype(np.float32)


def veiling_glare(rx, ry, rz, sun: np.ndarray, *, amplitude: float, bloom_gain: float, bloom_deg: float) -> np.ndarray:
    """Veiling glare plus bloom around the sun, float32 per pixel (frame units).

    ``amplitude/(θ² + θ0²) + bloom_gain·exp(−θ²/θ_b²)`` with θ in degrees between a
    pixel's ray and the sun (small-angle form ``θ² ≈ 2(1 − cos θ)``).
    """
    cos_t = rx * np.float32(sun[0]) + ry * np.float32(sun[1]) + rz * np.float32(sun[2])
    t2 = (1.0 - cos_t) * np.float32(2.0 * _DEG2)
    out = np.float32(amplitude) / (t2 + np.float32(_THETA0_DEG2))
    if bloom_gain > 0 and bloom_deg > 0:
        out += np.float32(bloom_gain) * fast_exp(t2 * np.float32(-1.0 / bloom_deg**2))
    return out


@dataclass(frozen=True)
class GlareParams(Params):
    """Physical parameters of the sun and the road's specular reflection.

    Parameters
    ----------
    sun_azimuth_deg : float or None
        World heading towards the sun, degrees; ``None`` draws one per episode.
    sun_elevation_deg : float
        Sun elevation above the horizon, degrees.
    sun_sky_ratio : float
        Direct-to-sky irradiance ratio ``E_sun/E_sky`` (broadband); 0 is an overcast
        sky (no glare).
    roughness : float
        Beckmann rms slope of the dry road.
    wetness : float
        Fraction of the road under a smooth water film.
    veil_coeff : float
        Stray-light coefficient k of the lens and windscreen (deg², Stiles–Holladay
        units; 10 for the human eye).
    bloom_deg : float
        Angular radius of the sensor's bloom around the sun, degrees.
    bloom_gain : float
        Peak bloom radiance relative to white.

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "sun_azimuth_deg": SUN_AZIMUTH_LIMIT,
        "sun_elevation_deg": Limit(0.5, 89.0, "degrees"),
        "sun_sky_ratio": Limit(0.0, 50.0),
        "roughness": Limit(0.02, 1.0),
        "wetness": Limit(0.0, 1.0),
        "veil_coeff": Limit(0.0, 50.0, "deg^2"),
        "bloom_deg": Limit(0.0, 10.0, "degrees"),
        "bloom_gain": Limit(0.0, 1000.0),
    }

    sun_azimuth_deg: float | None = 0.0
    sun_elevation_deg: float = 15.0
    sun_sky_ratio: float = 6.0
    roughness: float = 0.35
    wetness: float = 0.0
    veil_coeff: float = 1.5
    bloom_deg: float = 1.5
    bloom_gain: float = 50.0

    @classmethod
    def from_severity(cls, severity: float) -> GlareParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(
            sun_elevation_deg=21.0 - 16.0 * s,
            sun_sky_ratio=6.0 if s > 0 else 0.0,
            wetness=0.5 * s,
            veil_coeff=0.5 + 2.5 * s,
        )

    @property
    def is_identity(self) -> bool:
        return self.sun_sky_ratio == 0.0


def _upsample(half: np.ndarray, half_rows: slice, rows: slice, width: int) -> np.ndarray:
    """Resize a field computed on every other pixel (rows ``half_rows``) to ``rows``."""
    full = cv2.resize(half, (2 * half.shape[1], 2 * half.shape[0]), interpolation=cv2.INTER_LINEAR)
    off = rows.start - 2 * half_rows.start
    return np.ascontiguousarray(full[off : off + rows.stop - rows.start, :width])


class GlareModel(NoiseModel):
    """Specular sun glare on the road, veiling glare and bloom (module docstring)."""

    name = "glare"
    params_type = GlareParams
    stages = ("reflection", "optics")

    def _on_reset(self) -> None:
        p = self.params
        self.sun = draw_sun(self._require_reset(), p.sun_azimuth_deg, p.sun_elevation_deg)

    def _sun_terms(self, state: FrameState) -> tuple[np.ndarray, float, np.ndarray]:
        """Sun direction (ego), E_sun/E_ref after the atmosphere, and colour."""
        az, el = self.sun
        r = self.params.sun_sky_ratio
        t_sun = math.exp(-state.sun_optical_depth / math.sin(el))
        ratio = r * t_sun / (r * t_sun * math.sin(el) + 1.0)
        # In the frame's units a white surface is NOMINAL_EXPOSURE, not 1.
        return sun_direction_ego(az, el, state.camera.pose[2]), ratio * NOMINAL_EXPOSURE, sun_colour(el)

    def reflection(self, state: FrameState) -> None:
        p = self.params
        # The sun is out: the sky clears with it (shared with the shadow model's sun).
        t_sun = math.exp(-state.sun_optical_depth / math.sin(self.sun[1]))
        clear_sky(state, self.sun, t_sun * p.sun_sky_ratio / CLEAR_SKY_RATIO)
        geom = view_geometry(state.camera)
        sun, ratio, colour = self._sun_terms(state)
        rows = state.ground_rows
        half = slice(rows.start // 2, (rows.stop + 1) // 2)
        rx, ry, rz = (plane[half] for plane in geom.ray_planes_half)
        wet = max(p.wetness, state.water_film)
        lobe = np.float32(1.0 - wet) * specular_lobe(rx, ry, rz, sun, p.roughness, 0.04)
        if wet > 0:
            lobe += np.float32(wet) * specular_lobe(rx, ry, rz, sun, WATER_ROUGHNESS, 0.02)
        lobe = _upsample(lobe, half, rows, state.shape[1])
        lobe *= material_weights(state, _SPEC, 1.0)[rows] * np.float32(math.pi * ratio)
        if state.sun_visibility is not None:
            lobe *= state.sun_visibility[rows]
        state.lin[rows] += cv2.merge([lobe * c for c in colour])

    def optics(self, state: FrameState) -> None:
        p = self.params
        geom = view_geometry(state.camera)
        sun, ratio, colour = self._sun_terms(state)
        cos_axis = float(geom.R_ego[2] @ sun)
        if cos_axis <= 0.0:
            return  # the sun is behind the lens plane
        visible = self._sun_unoccluded(state, geom, sun)
        amp = math.pi * p.veil_coeff * ratio * cos_axis * visible
        bloom = p.bloom_gain * NOMINAL_EXPOSURE * math.exp(-state.sun_optical_depth / math.sin(self.sun[1])) * visible
        veil = veiling_glare(*geom.ray_planes_half, sun, amplitude=amp, bloom_gain=bloom, bloom_deg=p.bloom_deg)
        h, w = state.shape
        veil = _upsample(veil, slice(0, veil.shape[0]), slice(0, h), w)
        state.lin += cv2.merge([veil * c for c in colour])

    @staticmethod
    def _sun_unoccluded(state: FrameState, geom, sun: np.ndarray) -> float:
        """0 if the sun falls inside the frame on a vehicle, else 1."""
        u, v, z = geom.ego_to_image(sun[None, :])
        if z[0] <= 0:
            return 1.0
        col, row = int(round(u[0])), int(round(v[0]))
        h, w = state.shape
        if not (0 <= col < w and 0 <= row < h):
            return 1.0
        if state.material is not None:
            return 1.0 if state.material[row, col] == SKY else 0.0
        return 0.0 if np.isfinite(state.depth[row, col]) else 1.0
