"""Rain: falling drops as streaks (paper eq. 19), rain haze and a wet road.

Physics
-------
* **Drop sizes** — Marshall & Palmer (1948): ``N(D) = N0·exp(−Λ·D)`` with
  ``N0 = 8000 m⁻³ mm⁻¹`` and ``Λ = 4.1·R^−0.21 mm⁻¹`` for a rain rate R in mm/h;
  diameters 0.5–7 mm (radius a ≤ 3.5 mm, larger drops break up).
* **Fall speed** — Gunn & Kinzer (1949) measurements through the Atlas et al. (1973)
  fit ``v = 9.65 − 10.3·exp(−0.6·D)`` m/s (D in mm). The paper's ``v = 200·√a``
  (a in m) is available as ``terminal_velocity(a, model="sqrt")``.
* **Streaks** — each drop is a particle in 3-D around the camera that falls, drifts
  with the wind and moves relative to the ego (speed and yaw rate); its streak is
  its projected path during the exposure T, blended by ``I = β·I_E + (1 − β)·I_b``
  (eq. 19, see :mod:`simroad.noise._streaks` for β). A drop that covers a pixel
  has ``β = τ/T`` with ``τ ≈ 4a/v``: at most ≈ 1.5 ms (a = 3.5 mm, v = 9.5 m/s), so
  at the default exposure T = 1/500 s β ≤ 0.74 (0.25 for a 1 mm drop;
  :func:`exposure_beta`); a video camera's 1/30 s would give β ≤ 0.045, the long
  faint streaks of Garg & Nayar. The drop's radiance is that of its wide-angle
  view of the environment (Garg & Nayar): ``I_E = 0.94·mean scene luminance +
  0.06·sky luminance``, grey (a drop averages the colours of a ~165° view).
* **Haze** — the drops' extinction in the geometric-optics limit (efficiency 2):
  ``β_ext = 2·∫πa²N(D)dD = π·N0/Λ³`` (≈ 1.6·10⁻³ /m at 10 mm/h, visibility 2.5 km;
  6.8·10⁻³ /m at 100 mm/h, 580 m), applied with Koschmieder's law; ``haze_scale``
  multiplies it (e.g. > 1 for spray from traffic).
* **Wet road** — a water film darkens a rough surface of albedo A to
  ``A_w = (1 − R_e)(1 − R_i)·A / (1 − R_i·A)`` (Lekner & Dorf 1988; R_e = 0.066,
  ``R_i = 1 − (1 − R_e)/n²`` for water, n = 1.333), and mirrors the environment (seen
  through the rain) where standing water forms a smooth film (``water_film``), with
  the Fresnel reflectance of the viewing angle, blurred vertically by the film's
  ripples. From a camera 1.3 m up the road is seen at 63–90° incidence (Fresnel
  0.08–1), so a soaked road is darker near the car and shines with the sky farther
  away.

Severity mapping (:meth:`RainParams.from_severity`), s in [0, 1]::

    rate_mm_h   = 100 · s²        # 6 mm/h (s=0.25, moderate) … 25 (0.5, heavy) … 100 (1, violent)
    wind_m_s    = 8 · s           # blowing towards world +y (across highway-env's roads)
    wetness     = min(1, 2·s)     # soaked fraction of the surface (darkening)
    water_film  = 0.6 · s²        # standing water (mirror): 0.04 at 6 mm/h, 0.15 at 25, 0.6 at 100
    exposure_s  = 1/500           # fixed: a dashcam's daylight exposure (f/1.8, EV 11)
    haze_scale  = 1               # drops only

Individual streaks are sparse at 320x180, as in real footage at that resolution:
only drops within a metre or two are wider than a pixel, and a narrower drop's β is
scaled by the fraction ``d²`` of the pixel it covers, so at T = 1/500 s the streaks
are short (a drop at 8 m/s moves 1.6 cm) and most drops change the pixels they cross
by little; the rest of the rain shows as haze. Drops whose image is narrower than
0.25 px are not simulated one by one, and at most ``max_particles`` (default 2500,
the largest first) are: at 100 mm/h that keeps 2500 of 12 200 drops in range and
about half of the pixels their streaks would change (at 25 mm/h: 2500 of 5200, about
as many changed pixels, since the largest drops make most of them). The cost per
frame grows linearly with the number of drops drawn (``make bench`` times it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar

import cv2
import numpy as np

from simroad.camera.codes import ASPHALT, MARKING, ROADSIDE, SHOULDER
from simroad.core.constants import WATER_N
from simroad.core.validation import check_choice, check_in_range
from simroad.noise import _particles as pt
from simroad.noise._arrays import gray3, material_weights
from simroad.noise._geometry import ViewGeometry, view_geometry
from simroad.noise._particle_field import X_NEAR_M, ParticleField, sample_field
from simroad.noise.context import FrameState
from simroad.noise.fog import koschmieder
from simroad.noise.model import Limit, Params

__all__ = [
    "RainModel",
    "RainParams",
    "drop_radiance",
    "exposure_beta",
    "marshall_palmer",
    "marshall_palmer_slope",
    "rain_extinction",
    "terminal_velocity",
    "wet_albedo",
]

MP_N0 = 8000.0  # m^-3 mm^-1
LUMA = np.array([0.2126, 0.7152, 0.0722])  # linear-light luminance weights (Rec. 709)
D_RANGE_MM = (0.5, 7.0)
_R_E = 0.066
_R_I = 1.0 - (1.0 - _R_E) / WATER_N**2
SKY_PATH_M = 1000.0  # depth of rain the sky is seen through
_DARKEN = {ASPHALT: 1.0, MARKING: 1.0, SHOULDER: 0.8, ROADSIDE: 0.5}
_MIRROR = {ASPHALT: 1.0, MARKING: 0.8, SHOULDER: 0.3}


def marshall_palmer_slope(rate_mm_h: float) -> float:
    """Slope Λ of the Marshall–Palmer distribution in mm⁻¹: ``4.1·R^−0.21`` (R in mm/h, > 0)."""
    return 4.1 * rate_mm_h**-0.21


def marshall_palmer(diameter_mm: np.ndarray, rate_mm_h: float) -> np.ndarray:
    """Marshall–Palmer drop size distribution N(D) in m⁻³ mm⁻¹ (D in mm, R in mm/h)."""
    lam = marshall_palmer_slope(rate_mm_h)
    return MP_N0 * np.exp(-lam * np.asarray(diameter_mm, dtype=float))


def terminal_velocity(radius_m: np.ndarray | float, *, model: str = "gunn_kinzer") -> np.ndarray:
    """Terminal fall speed of a raindrop in m/s.

    Parameters
    ----------
    radius_m : array_like
        Drop radius a in m.
    model : {"gunn_kinzer", "sqrt"}
        ``"gunn_kinzer"``: Atlas et al.'s fit to Gunn & Kinzer, with their
        measurements interpolated below D = 0.3 mm. ``"sqrt"``: ``v = 200·√a``
        (Garg & Nayar's approximation, too fast for large drops).
    """
    model = check_choice("model", model, ["gunn_kinzer", "sqrt"])
    a = np.asarray(radius_m, dtype=float)
    if model == "sqrt":
        return 200.0 * np.sqrt(a)
    d_mm = 2e3 * a
    fit = 9.65 - 10.3 * np.exp(-0.6 * d_mm)
    small = np.interp(d_mm, [0.0, 0.1, 0.2, 0.3], [0.0, 0.27, 0.72, 1.17])
    return np.where(d_mm < 0.3, small, fit)


def exposure_beta(radius_m: np.ndarray | float, speed_m_s: np.ndarray | float, exposure_s: float) -> np.ndarray:
    """Garg & Nayar's blending weight of a pixel covered by a moving drop (eq. 19).

    ``β = τ/T`` with ``τ = 4a/v`` the longest time the drop stays on one pixel,
    clipped to 1 (a drop slower than that covers the pixel the whole exposure).
    """
    a = np.asarray(radius_m, dtype=float)
    v = np.maximum(np.asarray(speed_m_s, dtype=float), 1e-9)
    return np.minimum(1.0, 4.0 * a / (v * exposure_s))


def rain_extinction(rate_mm_h: float) -> float:
    """Extinction coefficient of rain in 1/m: ``π·N0/Λ³`` (geometric optics)."""
    if rate_mm_h <= 0:
        return 0.0
    lam = marshall_palmer_slope(rate_mm_h)
    return math.pi * MP_N0 / lam**3 * 1e-6


def drop_radiance(scene_mean: np.ndarray, ambient: np.ndarray) -> np.ndarray:
    """Radiance of a drop, ``0.94·Y(scene mean) + 0.06·Y(ambient)``, grey (3,).

    A drop refracts a ~165° view of its surroundings (Garg & Nayar), which averages
    their colours away: drops are achromatic. Y is the linear luminance
    ``0.2126 R + 0.7152 G + 0.0722 B``.
    """
    y = 0.94 * float(np.dot(LUMA, scene_mean)) + 0.06 * float(np.dot(LUMA, ambient))
    return np.full(3, y, dtype=np.float32)


def wet_albedo(albedo: np.ndarray, wetness: np.ndarray | float) -> np.ndarray:
    """Albedo of a rough surface under a water film (Lekner & Dorf 1988).

    Parameters
    ----------
    albedo : ndarray
        Dry albedo (linear relative radiance), in [0, 1].
    wetness : float or ndarray
        Fraction of the surface under water, in [0, 1].
    """
    wet = (1.0 - _R_E) * (1.0 - _R_I) * albedo / (1.0 - _R_I * albedo)
    return albedo + wetness * (wet - albedo)


@dataclass(frozen=True)
class RainParams(Params):
    """Physical parameters of rain.

    Parameters
    ----------
    rate_mm_h : float
        Rain rate in mm/h.
    wind_m_s : float
        Horizontal wind speed in m/s.
    wind_dir_deg : float
        World heading the wind blows towards, degrees (0 = world +x).
    exposure_s : float
        Camera exposure time T in s.
    wetness : float
        Fraction of the ground whose pores are soaked (darkens it).
    water_film : float
        Fraction of the road under a smooth film of standing water that mirrors the
        environment (and the sun, for the glare model).
    haze_scale : float
        Multiplier of the drops' extinction.
    airlight : float
        Radiance of the rain-filled horizon (linear).
    max_particles : int
        Budget of simulated drops (the cost per frame grows linearly with it; see
        the module docstring and ``make bench``).

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "rate_mm_h": Limit(0.0, 300.0, "mm/h"),
        "wetness": Limit(0.0, 1.0),
        "water_film": Limit(0.0, 1.0),
        "haze_scale": Limit(0.0, 100.0),
        "airlight": Limit(0.0, 1.0),
        **pt.PARTICLE_LIMITS,
    }

    rate_mm_h: float = 25.0
    wind_m_s: float = 4.0
    wind_dir_deg: float = 90.0
    exposure_s: float = 1.0 / 500.0
    wetness: float = 1.0
    water_film: float = 0.15
    haze_scale: float = 1.0
    airlight: float = 0.45
    max_particles: int = 2500

    @classmethod
    def from_severity(cls, severity: float) -> RainParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(rate_mm_h=100.0 * s * s, wind_m_s=8.0 * s, wetness=min(1.0, 2.0 * s), water_film=0.6 * s * s)

    @property
    def is_identity(self) -> bool:
        return self.rate_mm_h == 0.0 and self.wetness == 0.0 and self.water_film == 0.0


@lru_cache(maxsize=16)
def _mirror_maps_cached(geom: ViewGeometry, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
    mx, my = geom.mirror_map
    return cv2.convertMaps(mx[start:stop:2, ::2], my[start:stop:2, ::2], cv2.CV_16SC2, nninterpolation=True)


def _mirror_maps(geom: ViewGeometry, rows: slice) -> tuple[np.ndarray, np.ndarray]:
    """Fixed-point remap tables of the wet road's mirror image for every other pixel
    of ``rows`` (the ripple-blurred reflection is built at half resolution)."""
    return _mirror_maps_cached(geom, rows.start, rows.stop)


class RainModel(pt.ParticleModel):
    """Rain drops, rain haze and a wet road (see the module docstring)."""

    name = "rain"
    params_type = RainParams
    stages = ("material", "reflection", "atmosphere", "particles")

    def prepare(self, state: FrameState) -> None:
        state.water_film = max(state.water_film, self.params.water_film)

    def material(self, state: FrameState) -> None:
        w = self.params.wetness
        if w == 0.0:
            return
        r = state.ground_rows
        weight = material_weights(state, _DARKEN, 1.0)[r] * np.float32(w)
        lin = state.lin[r]
        denom = cv2.addWeighted(lin, -_R_I, lin, 0.0, 1.0)  # 1 - R_i·A
        wet = cv2.divide(lin, denom, scale=(1.0 - _R_E) * (1.0 - _R_I))  # wet_albedo(A, 1)
        wet -= lin
        wet *= gray3(weight)
        lin += wet

    def reflection(self, state: FrameState) -> None:
        w = self.params.water_film
        if w == 0.0:
            return
        geom = view_geometry(state.camera)
        r = state.ground_rows
        m1, m2 = _mirror_maps(geom, r)
        refl = cv2.remap(state.lin, m1, m2, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
        beta = self.params.haze_scale * rain_extinction(self.params.rate_mm_h)
        if beta > 0.0:  # mirrored rays mostly reach the sky through the rain: a rainy sky
            t = math.exp(-beta * SKY_PATH_M)
            cv2.addWeighted(refl, t, refl, 0.0, (1.0 - t) * self.params.airlight, dst=refl)
        refl = cv2.blur(refl, (3, 5))  # ripples: about 3 x 9 pixels at full resolution
        refl = cv2.resize(refl, (state.shape[1], r.stop - r.start), interpolation=cv2.INTER_LINEAR)
        k = material_weights(state, _MIRROR, 1.0)[r] * geom.fresnel_water[r] * np.float32(w)
        refl *= gray3(k)
        state.lin[r] += refl

    def atmosphere(self, state: FrameState) -> None:
        p = self.params
        beta = p.haze_scale * rain_extinction(p.rate_mm_h)
        if beta > 0.0:
            koschmieder(state.lin, state.depth, beta, p.airlight, sky_path_m=SKY_PATH_M)

    def _sample(self, geom) -> ParticleField:
        p = self.params
        edges = np.linspace(*D_RANGE_MM, 53)
        lam = marshall_palmer_slope(p.rate_mm_h)
        dens = MP_N0 / lam * (np.exp(-lam * edges[:-1]) - np.exp(-lam * edges[1:]))
        return sample_field(
            self._require_reset(),
            geom,
            diameter_edges_mm=edges,
            density_per_bin=dens,
            fall_speed=lambda d_mm, rng: terminal_velocity(d_mm * 5e-4),
            d_min_px=0.25,
            x_near_m=X_NEAR_M,
            max_particles=p.max_particles,
        )

    def _has_particles(self) -> bool:
        return self.params.rate_mm_h > 0.0 and self.params.max_particles > 0

    def _radiance(self, state: FrameState) -> np.ndarray:
        return drop_radiance(state.scene_mean(), state.sky_radiance())
