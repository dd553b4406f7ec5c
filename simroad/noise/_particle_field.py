"""The particle field of rain and snow: drawing particles around the camera and moving them.

Particles live in the ego frame, relative to the camera (X forward, Y right, Z down;
the road is Z = +h). Each particle has its own box in front of the camera, periodic
in all three axes: a drop leaving through the road re-enters at the top, one passed
by the car re-enters at the far end. Rigid motions (falling, wind, the ego's speed and
yaw) followed by a periodic wrap keep the density uniform, and need no new random
draws, so a field evolves deterministically from its initial draw.

The box of a particle of diameter D reaches as far as its image is at least
``d_min_px`` pixels wide (``x_far = D·f / d_min_px``): farther particles change a
pixel by less than a grey level each and are accounted for by the haze term instead.
Small particles therefore live in small boxes, which keeps the count affordable.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from simroad.noise._geometry import ViewGeometry

__all__ = [
    "X_NEAR_M",
    "ParticleField",
    "advance",
    "particle_velocity",
    "relative_velocity",
    "sample_field",
    "wind_in_ego",
]

#: Free-falling drops and flakes start this far ahead of the camera, beyond the windscreen (m).
X_NEAR_M = 0.6


@dataclass
class ParticleField:
    """State of the particles (arrays of length N; positions in metres, see module).

    Attributes
    ----------
    pos : ndarray (N, 3)
        Camera-relative ego-frame positions, m.
    max_speed, max_drift : float
        Largest fall plus flutter speed and largest flutter amplitude, m/s.
    radius_m : ndarray (N,)
        Particle radius, m.
    fall_m_s : ndarray (N,)
        Fall speed relative to the air, m/s.
    lo, size : ndarray (N, 3)
        Lower corner and size of each particle's periodic box, m.
    drift_amp, drift_freq, drift_phase : ndarray (N,)
        Horizontal flutter: amplitude m/s, frequency Hz, phase rad (0 for rain).
    drift_dir : ndarray (N, 2)
        Unit horizontal direction of the flutter in the ego frame.
    """

    pos: np.ndarray
    radius_m: np.ndarray
    fall_m_s: np.ndarray
    lo: np.ndarray
    size: np.ndarray
    drift_amp: np.ndarray
    drift_freq: np.ndarray
    drift_phase: np.ndarray
    drift_dir: np.ndarray

    def __len__(self) -> int:
        return len(self.radius_m)

    def __post_init__(self) -> None:
        self.max_drift = float(self.drift_amp.max()) if len(self) else 0.0
        self.max_speed = float(self.fall_m_s.max()) + self.max_drift if len(self) else 0.0


def _box_extent(geom: ViewGeometry, x_far: np.ndarray, x_near: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-particle box lower corners and sizes for far limits ``x_far`` (m)."""
    pitch = np.radians(geom.config.pitch_deg)
    y_half = x_far * np.tan(geom.half_fov_x) + 0.5
    z_up = x_far * np.tan(max(geom.half_fov_y - pitch, 0.0)) + 0.5
    lo = np.column_stack([np.full_like(x_far, x_near), -y_half, -z_up])
    size = np.column_stack([x_far - x_near, 2 * y_half, z_up + geom.height_m])
    return lo, size


def _within_budget(expected: np.ndarray, budget: int) -> np.ndarray:
    """Expected counts per size bin, keeping the largest sizes first up to ``budget``
    particles (the boundary bin partly)."""
    rev = expected[::-1]
    before = np.concatenate([[0.0], np.cumsum(rev)[:-1]])
    kept = np.clip(budget - before, 0.0, rev)
    return kept[::-1]


def sample_field(
    rng: np.random.Generator,
    geom: ViewGeometry,
    *,
    diameter_edges_mm: np.ndarray,
    density_per_bin: np.ndarray,
    fall_speed: Callable[[np.ndarray, np.random.Generator], np.ndarray],
    d_min_px: float,
    x_near_m: float,
    max_particles: int,
    drift_m_s: float = 0.0,
) -> ParticleField:
    """Draw the particles of a size distribution in their boxes.

    Parameters
    ----------
    diameter_edges_mm : ndarray (B + 1,)
        Edges of the diameter bins, mm.
    density_per_bin : ndarray (B,)
        Number density of each bin, 1/m³.
    fall_speed : callable (diameter_mm, rng) -> m/s
    d_min_px : float
        Smallest image width (px) at which a particle is simulated (sets its box).
    x_near_m : float
        Nearest distance ahead of the camera, m (the windscreen).
    max_particles : int
        Budget; past it the smallest particles are left to the haze term.
    drift_m_s : float
        Flutter amplitude (snow), m/s.
    """
    mid_mm = 0.5 * (diameter_edges_mm[1:] + diameter_edges_mm[:-1])
    x_far = np.clip(mid_mm * 1e-3 * geom.fx / d_min_px, x_near_m + 0.5, 25.0)
    lo_b, size_b = _box_extent(geom, x_far, x_near_m)
    expected = _within_budget(density_per_bin * size_b.prod(axis=1), max_particles)
    total = int(round(expected.sum()))
    if total == 0:
        counts = np.zeros(len(mid_mm), dtype=int)
    else:
        counts = rng.multinomial(total, expected / expected.sum())
    b = np.repeat(np.arange(len(mid_mm)), counts)
    n = len(b)
    d_mm = rng.uniform(diameter_edges_mm[b], diameter_edges_mm[b + 1])
    lo, size = lo_b[b], size_b[b]
    pos = lo + rng.random((n, 3)) * size
    ang = rng.uniform(0.0, 2 * np.pi, n)
    return ParticleField(
        pos=pos,
        radius_m=d_mm * 5e-4,
        fall_m_s=fall_speed(d_mm, rng),
        lo=lo,
        size=size,
        drift_amp=drift_m_s * rng.uniform(0.5, 1.0, n) if drift_m_s > 0 else np.zeros(n),
        drift_freq=rng.uniform(0.3, 1.0, n),
        drift_phase=rng.uniform(0.0, 2 * np.pi, n),
        drift_dir=np.column_stack([np.cos(ang), np.sin(ang)]),
    )


def particle_velocity(
    field: ParticleField, wind_ego: np.ndarray, time_s: float, idx: np.ndarray | None = None
) -> np.ndarray:
    """Velocity over the ground in the ego frame (N, 3), m/s, of all or ``idx`` particles."""
    sel = slice(None) if idx is None else idx
    fall = field.fall_m_s[sel]
    vel = np.empty((len(fall), 3))
    vel[:, 0] = wind_ego[0]
    vel[:, 1] = wind_ego[1]
    vel[:, 2] = fall
    if field.max_drift > 0:
        s = field.drift_amp[sel] * np.sin(2 * np.pi * field.drift_freq[sel] * time_s + field.drift_phase[sel])
        vel[:, :2] += s[:, None] * field.drift_dir[sel]
    return vel


def relative_velocity(pos: np.ndarray, vel: np.ndarray, speed: float, yaw_rate: float, forward_m: float) -> np.ndarray:
    """Velocity relative to the moving, turning camera (N, 3), m/s.

    ``pos`` are camera-relative ego positions (N, 3). A yaw rate ω (positive to the
    right) turns a static point about the ego centre as ``dX/dt = ω·Y``,
    ``dY/dt = −ω·X`` (X measured from the ego centre, ``forward_m`` behind the camera).
    """
    rel = vel.copy()
    rel[:, 0] += -speed + yaw_rate * pos[:, 1]
    rel[:, 1] += -yaw_rate * (pos[:, 0] + forward_m)
    return rel


def advance(
    field: ParticleField,
    dt: float,
    *,
    wind_ego: np.ndarray,
    speed: float,
    yaw_rate: float,
    forward_m: float,
    time_s: float,
) -> None:
    """Move every particle by ``dt`` seconds in place (fall, wind, ego motion, wrap)."""
    vel = particle_velocity(field, wind_ego, time_s)
    p = field.pos
    vel *= dt
    p += vel
    p[:, 0] -= speed * dt
    if yaw_rate != 0.0:
        th = yaw_rate * dt
        c, s = np.cos(th), np.sin(th)
        xc = p[:, 0] + forward_m
        yc = p[:, 1].copy()
        p[:, 0] = xc * c + yc * s - forward_m
        p[:, 1] = -xc * s + yc * c
    q = (p - field.lo) / field.size
    q -= np.floor(q)
    q *= field.size
    np.add(q, field.lo, out=p)


def wind_in_ego(speed_m_s: float, dir_deg: float, heading_rad: float) -> np.ndarray:
    """World wind (speed, heading it blows towards) as ego (forward, right) m/s."""
    phi = math.radians(dir_deg) - heading_rad
    return np.array([speed_m_s * math.cos(phi), speed_m_s * math.sin(phi)])
