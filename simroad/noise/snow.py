"""Snow: falling flakes (paper eq. 19), snow haze and snow settled beside the road.

Physics
-------
* **Flakes** — diameters 1–5 mm from an exponential distribution
  ``N(D) ∝ exp(−Λ·D)``, Λ = 0.8 mm⁻¹ (the Gunn & Marshall 1958 form), normalised to
  ``flake_density_m3`` flakes per m³. Fall speed of unrimed aggregates
  ``v = 0.8·D^0.16`` m/s (Locatelli & Hobbs 1974, D in mm) scattered ±25 %
  (log-normal) and clipped to 0.5–2 m/s, plus wind and a horizontal flutter
  (``drift_m_s``, 0.3–1 Hz) that makes flakes wander.
* **Blending** — the same exposure blending as rain (eq. 19, see
  :mod:`simroad.noise._particles`), but flakes are slow and opaque: a 5 mm flake at
  1 m/s stays ``τ = 4a/v = 10 ms`` on a pixel: β = 1 (frozen flakes) at the default
  T = 1/500 s (:func:`flake_beta`), against at most 0.74 for a raindrop; even at a
  video camera's 1/30 s, β = 0.3, seven times a raindrop's 0.045.
  Flake radiance is near-white: ``I_E = flake_albedo`` of the white reference.
* **Haze** — the flakes' geometric-optics extinction ``β_ext = 2·n·π⟨r²⟩``
  (≈ 7.8·10⁻³ /m, visibility 500 m, at 1000 flakes/m³), with Koschmieder's law.
* **Settled snow** — with ``settle`` > 0, a world-anchored patchy cover (value noise
  over world ground coordinates, 2 m and 0.5 m scales) of fraction ≈ ``settle``
  on the roadside and shoulders (materials ROADSIDE and SHOULDER; the road too if
  ``settle_on_road``). Needs the material map.

Severity mapping (:meth:`SnowParams.from_severity`), s in [0, 1]::

    flake_density_m3 = 3000 · s^1.5            # 1060 /m³ at s=0.5 (visibility ≈ 450 m), 3000 at s=1 (≈ 160 m)
    wind_m_s         = 6 · s
    drift_m_s        = 0.4
    exposure_s       = 1/500                    # as rain: a daylight dashcam
    settle           = 0.9 · clip((s − 0.5)/0.5, 0, 1)   # no cover below s = 0.5
    settle_on_road   = False
    max_particles    = 2500                     # see below

Particle budget: only flakes whose image is at least 0.15 px wide are simulated one
by one, and at most ``max_particles`` of them, the largest first; the others act
through the haze term, which integrates the whole size distribution. Snow is dense:
at s = 1 about 157 000 flakes are in range, and the default budget keeps the 2500
largest, so heavy snowfall lacks the fine speckle of its many small far flakes
(measured on a racetrack frame: 800 pixels changed by flakes instead of 35 000, and
at s = 0.5, 760 instead of 15 600; the cost per frame grows linearly with the number
of flakes drawn, so an unlimited budget at s = 1 costs about 60 times the default's
particle work — ``make bench`` times it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np

from simroad.camera.codes import ASPHALT, MARKING, ROADSIDE, SHOULDER
from simroad.core.validation import check_in_range
from simroad.noise import _particles as pt
from simroad.noise._arrays import gray3, material_weights, rgb_scalar, smoothstep
from simroad.noise._geometry import ego_to_world, view_geometry
from simroad.noise._particle_field import X_NEAR_M, ParticleField, sample_field
from simroad.noise.context import FrameState
from simroad.noise.fog import koschmieder
from simroad.noise.model import Limit, Params
from simroad.noise.rain import exposure_beta

__all__ = [
    "SnowModel",
    "SnowParams",
    "flake_beta",
    "flake_fall_speed",
    "noise_lattice",
    "snow_cover",
    "snow_extinction",
]

D_RANGE_MM = (1.0, 5.0)
SIZE_SLOPE_PER_MM = 0.8
SNOW_RGB = np.array([0.80, 0.82, 0.86], dtype=np.float32)  # linear, slightly blue
_BESIDE = {ROADSIDE: 1.0, SHOULDER: 1.0}
_ROAD_TOO = {ROADSIDE: 1.0, SHOULDER: 1.0, ASPHALT: 1.0, MARKING: 1.0}


def flake_fall_speed(diameter_mm: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
    """Fall speed of snowflakes in m/s: ``0.8·D^0.16`` (Locatelli & Hobbs 1974).

    With ``rng``, each flake's speed is scattered log-normally by 25 %; the result is
    clipped to 0.5–2 m/s.
    """
    v = 0.8 * np.asarray(diameter_mm, dtype=float) ** 0.16
    if rng is not None:
        v = v * np.exp(rng.normal(0.0, 0.25, v.shape))
    return np.clip(v, 0.5, 2.0)


def flake_beta(diameter_mm: np.ndarray | float, speed_m_s: np.ndarray | float, exposure_s: float) -> np.ndarray:
    """Eq. 19's β of a pixel covered by a flake: ``min(1, 4a/(v·T))``."""
    return exposure_beta(np.asarray(diameter_mm, dtype=float) * 5e-4, speed_m_s, exposure_s)


def _bins(density_m3: float) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(*D_RANGE_MM, 33)
    w = np.exp(-SIZE_SLOPE_PER_MM * edges[:-1]) - np.exp(-SIZE_SLOPE_PER_MM * edges[1:])
    return edges, density_m3 * w / w.sum()


def snow_extinction(flake_density_m3: float) -> float:
    """Extinction coefficient in 1/m: ``2·Σ n_i·π·r_i²`` over the size bins."""
    edges, dens = _bins(flake_density_m3)
    mid_r = 0.25e-3 * (edges[1:] + edges[:-1])
    return float(2.0 * np.sum(dens * math.pi * mid_r**2))


@dataclass(frozen=True)
class SnowParams(Params):
    """Physical parameters of snowfall.

    Parameters
    ----------
    flake_density_m3 : float
        Flakes of 1–5 mm per m³.
    wind_m_s : float
        Horizontal wind in m/s.
    wind_dir_deg : float
        World heading the wind blows towards, degrees.
    drift_m_s : float
        Amplitude of the flakes' horizontal flutter, m/s.
    exposure_s : float
        Camera exposure T in s.
    flake_albedo : float
        Flake radiance relative to white.
    settle : float
        Fraction of the roadside and shoulders covered by settled snow.
    settle_on_road : bool
        Let the cover reach the road surface and its markings too.
    airlight : float
        Radiance of the snowy horizon (linear).
    haze_scale : float
        Multiplier of the flakes' extinction (0: no haze).
    max_particles : int
        Budget of simulated flakes (the cost per frame grows linearly with it; see
        the module docstring and ``make bench``).

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes).
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "flake_density_m3": Limit(0.0, 20000.0, "1/m^3"),
        "drift_m_s": Limit(0.0, 3.0, "m/s"),
        "flake_albedo": Limit(0.0, 1.0),
        "settle": Limit(0.0, 1.0),
        "airlight": Limit(0.0, 1.0),
        "haze_scale": Limit(0.0, 100.0),
        **pt.PARTICLE_LIMITS,
    }

    flake_density_m3: float = 1000.0
    wind_m_s: float = 3.0
    wind_dir_deg: float = 90.0
    drift_m_s: float = 0.4
    exposure_s: float = 1.0 / 500.0
    flake_albedo: float = 0.85
    settle: float = 0.0
    settle_on_road: bool = False
    airlight: float = 0.75
    haze_scale: float = 1.0
    max_particles: int = 2500

    @classmethod
    def from_severity(cls, severity: float) -> SnowParams:
        """Documented severity mapping (see the module docstring)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(
            flake_density_m3=3000.0 * s**1.5,
            wind_m_s=6.0 * s,
            settle=0.9 * min(1.0, max(0.0, (s - 0.5) / 0.5)),
        )

    @property
    def is_identity(self) -> bool:
        return self.flake_density_m3 == 0.0 and self.settle == 0.0


def noise_lattice(seed: int, size: int = 256) -> np.ndarray:
    """Random lattice (size x size, float32 in [0, 1)) for value noise."""
    return np.random.default_rng([seed, 0x5A0]).random((size, size), dtype=np.float32)


def snow_cover(x: np.ndarray, y: np.ndarray, settle: float, lattice: np.ndarray) -> np.ndarray:
    """Fraction of ground covered by settled snow at world points (m), float32.

    Two octaves of value noise over world coordinates (lattices of 2 m and 0.5 m,
    bilinear, periodic every 256 lattice cells), thresholded so that about
    ``settle`` of the ground is covered, with soft edges.

    Parameters
    ----------
    x, y : ndarray float32 (H, W)
        World coordinates, m.
    lattice : ndarray float32 (L, L)
        From :func:`noise_lattice`.
    """
    n = 0.7 * _lattice_sample(lattice, x / 2.0, y / 2.0)
    n += 0.3 * _lattice_sample(lattice, x / 0.5 + 101.0, y / 0.5 + 37.0)
    return smoothstep((n - (1.0 - settle) * 0.85 - 0.05) / 0.15).astype(np.float32)


def _lattice_sample(lattice: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    n = np.float32(lattice.shape[0])

    def wrap(g: np.ndarray) -> np.ndarray:
        g = g.astype(np.float32)
        return g - n * np.floor(g / n)

    return cv2.remap(lattice, wrap(gx), wrap(gy), cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def _cover_map(geom, rows: slice, pose, settle: float, lattice: np.ndarray) -> np.ndarray:
    """Snow cover (float32, rows x W) of the ground seen by ``rows``, computed on every
    third pixel and upsampled (the cover varies over metres)."""
    x, y = ego_to_world(geom.ground_xy[rows][::3, ::3], pose)
    half = snow_cover(x, y, settle, lattice)
    return cv2.resize(half, (geom.config.width, rows.stop - rows.start), interpolation=cv2.INTER_LINEAR)


class SnowModel(pt.ParticleModel):
    """Snow flakes, snow haze and settled snow (see the module docstring)."""

    name = "snow"
    params_type = SnowParams
    stages = ("material", "atmosphere", "particles")

    def _on_reset(self) -> None:
        super()._on_reset()
        self._lattice: np.ndarray | None = None

    def cover_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Settled-snow fraction at world points (m), float32 in [0, 1]: the same
        patches :meth:`material` paints (0 everywhere when ``settle`` is 0). Where
        the cover lies (beside the road, or on it too) is ``settle_on_road``'s call."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float32), np.asarray(y, dtype=np.float32))
        if self.params.settle == 0.0:
            return np.zeros(x.shape, dtype=np.float32)
        if self._lattice is None:
            self._lattice = noise_lattice(self._seed)
        flat = snow_cover(x.reshape(1, -1), y.reshape(1, -1), self.params.settle, self._lattice)  # OpenCV maps are 2-D
        return flat.reshape(x.shape)

    def material(self, state: FrameState) -> None:
        p = self.params
        if p.settle == 0.0 or state.material is None:
            return
        r = state.ground_rows
        where = material_weights(state, _ROAD_TOO if p.settle_on_road else _BESIDE, 0.0)[r]
        if not where.any():
            return
        if self._lattice is None:
            self._lattice = noise_lattice(self._seed)
        c = _cover_map(view_geometry(state.camera), r, state.camera.pose, p.settle, self._lattice)
        c *= where
        lin = state.lin[r]
        d = cv2.subtract(lin, rgb_scalar(SNOW_RGB))  # type: ignore[call-overload]  # OpenCV's stubs omit scalar operands
        d *= gray3(c)
        lin -= d

    def atmosphere(self, state: FrameState) -> None:
        beta = self.params.haze_scale * snow_extinction(self.params.flake_density_m3)
        if beta > 0.0:
            koschmieder(state.lin, state.depth, beta, self.params.airlight)

    def _sample(self, geom) -> ParticleField:
        p = self.params
        edges, dens = _bins(p.flake_density_m3)
        return sample_field(
            self._require_reset(),
            geom,
            diameter_edges_mm=edges,
            density_per_bin=dens,
            fall_speed=flake_fall_speed,
            d_min_px=0.15,
            x_near_m=X_NEAR_M,
            max_particles=p.max_particles,
            drift_m_s=p.drift_m_s,
        )

    def _has_particles(self) -> bool:
        return self.params.flake_density_m3 > 0.0 and self.params.max_particles > 0

    def _radiance(self, state: FrameState) -> np.ndarray:
        return SNOW_RGB * np.float32(self.params.flake_albedo / SNOW_RGB.max())
