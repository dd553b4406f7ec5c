"""Falling particles (rain drops, snow flakes) around the camera and their streaks.

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

Photometry (paper eq. 19, Garg & Nayar 2004): during the exposure T a particle's
image, a disc of ``d`` pixels, moves ``L`` pixels. A pixel on its path is covered for
the time it takes the disc to cross it, ``τ = (d + 1)/L·T`` (which is Garg & Nayar's
``τ ≈ 4a/v`` when the disc is one pixel wide), over a fraction ``min(1, d)²`` of its
area, so it blends ``I = β·I_E + (1 − β)·I_b`` with
``β = min(1, d)² · min(1, (d + 1)/L)``. The β of all particles crossing a pixel add.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from simroad.noise._geometry import ViewGeometry, view_geometry
from simroad.noise.base import FrameState, NoiseModel, rgb_scalar

__all__ = [
    "ParticleField",
    "ParticleModel",
    "advance",
    "blend",
    "particle_velocity",
    "relative_velocity",
    "sample_field",
    "splat_streaks",
    "streaks",
    "wind_in_ego",
]

_Z_NEAR_M = 0.05
_MAX_WIDTH_PX = 15
_BETA_MIN = 2e-3  # below a tenth of a grey level on any background: not drawn


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


def _frustum_candidates(field: ParticleField, geom: ViewGeometry, margin_m: float) -> np.ndarray:
    """Indices of particles within ``margin_m`` of the view frustum (cheap pre-cull)."""
    pc = field.pos @ geom.R_ego.T
    z = pc[:, 2]
    tx = (geom.config.width / 2 + 2) / geom.fx
    ty = (geom.config.height / 2 + 2) / geom.fy
    ok = z > _Z_NEAR_M - margin_m
    ok &= np.abs(pc[:, 0]) <= z * tx + margin_m
    ok &= np.abs(pc[:, 1]) <= z * ty + margin_m
    return np.flatnonzero(ok)


def _clip_to_rect(x0, y0, x1, y1, xmin, xmax, ymin, ymax):
    """Vectorised Liang–Barsky: parameters (t0, t1) of the visible part, and validity."""
    dx, dy = x1 - x0, y1 - y0
    t0 = np.zeros_like(x0)
    t1 = np.ones_like(x0)
    valid = np.ones(x0.shape, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p, q in ((-dx, x0 - xmin), (dx, xmax - x0), (-dy, y0 - ymin), (dy, ymax - y0)):
            r = q / p
            t0 = np.where(p < 0, np.maximum(t0, r), t0)
            t1 = np.where(p > 0, np.minimum(t1, r), t1)
            valid &= ~((p == 0) & (q < 0))
    return t0, t1, valid & (t0 <= t1)


def streaks(
    field: ParticleField,
    geom: ViewGeometry,
    *,
    wind_ego: np.ndarray,
    speed: float,
    yaw_rate: float,
    exposure_s: float,
    time_s: float,
) -> tuple[np.ndarray, ...]:
    """Image streaks of the particles during the exposure ending now.

    Returns
    -------
    u0, v0, u1, v1 : ndarray
        Streak end points in pixels, clipped to the image.
    width : ndarray int
        Drawn width in pixels.
    beta : ndarray
        Per-pixel blending weight β of each streak (paper eq. 19).
    """
    if len(field) == 0:
        return (np.zeros(0),) * 4 + (np.zeros(0, dtype=np.int64), np.zeros(0))
    vmax = abs(speed) + float(np.hypot(*wind_ego)) + field.max_speed + abs(yaw_rate) * 30
    idx = _frustum_candidates(field, geom, margin_m=vmax * exposure_s + 0.05)
    end = field.pos[idx]
    rel = relative_velocity(end, particle_velocity(field, wind_ego, time_s, idx), speed, yaw_rate, geom.forward_m)
    start = end - rel * exposure_s
    ue, ve, ze = geom.ego_to_image(end)
    us, vs, zs = geom.ego_to_image(start)
    behind = (ze > _Z_NEAR_M) & (zs <= _Z_NEAR_M)
    if behind.any():
        f = (ze[behind] - _Z_NEAR_M) / (ze[behind] - zs[behind])
        mid = end[behind] + f[:, None] * (start[behind] - end[behind])
        us[behind], vs[behind], _ = geom.ego_to_image(mid)
    d = 2.0 * geom.fx * field.radius_m[idx] / np.maximum(ze, _Z_NEAR_M)
    length = np.hypot(ue - us, ve - vs)
    beta = np.minimum(d, 1.0) ** 2 * np.minimum(1.0, (d + 1.0) / np.maximum(length, 1e-9))
    keep = np.flatnonzero((ze > _Z_NEAR_M) & (beta >= _BETA_MIN))
    d, us, vs, ue, ve, beta = d[keep], us[keep], vs[keep], ue[keep], ve[keep], beta[keep]
    width = np.clip(np.rint(d), 1, _MAX_WIDTH_PX).astype(np.int64)
    W, H = geom.config.width, geom.config.height
    m = width / 2.0
    lo_u, hi_u, lo_v, hi_v = -0.5 - m, W - 0.5 + m, -0.5 - m, H - 0.5 + m
    # Samples off the image are dropped when splatting; clipping only bounds the
    # work of streaks much longer than the image.
    out = np.abs(ue - us) + np.abs(ve - vs) > W + H
    out &= (
        (np.minimum(us, ue) < lo_u)
        | (np.maximum(us, ue) > hi_u)
        | (np.minimum(vs, ve) < lo_v)
        | (np.maximum(vs, ve) > hi_v)
    )
    if not out.any():
        return us, vs, ue, ve, width, beta
    o = np.flatnonzero(out)
    t0, t1, ok = _clip_to_rect(us[o], vs[o], ue[o], ve[o], lo_u[o], hi_u[o], lo_v[o], hi_v[o])
    du, dv = ue[o] - us[o], ve[o] - vs[o]
    us[o], vs[o], ue[o], ve[o] = us[o] + t0 * du, vs[o] + t0 * dv, us[o] + t1 * du, vs[o] + t1 * dv
    vis = np.ones(len(d), dtype=bool)
    vis[o] = ok
    return us[vis], vs[vis], ue[vis], ve[vis], width[vis], beta[vis]


def _widen(u0, v0, u1, v1, width, beta):
    """Replace each streak ``width`` pixels wide by ``width`` parallel 1-pixel streaks,
    offset along its minor axis."""
    rep = np.repeat(np.arange(len(width)), width)
    off = np.arange(len(rep)) - np.repeat(np.cumsum(width) - width, width) - (width[rep] - 1) / 2.0
    steep = np.abs(v1 - v0) > np.abs(u1 - u0)
    ou = np.where(steep[rep], off, 0.0)
    ov = np.where(steep[rep], 0.0, off)
    return u0[rep] + ou, v0[rep] + ov, u1[rep] + ou, v1[rep] + ov, beta[rep]


def splat_streaks(
    u0: np.ndarray,
    v0: np.ndarray,
    u1: np.ndarray,
    v1: np.ndarray,
    width: np.ndarray,
    beta: np.ndarray,
    shape: tuple[int, int],
) -> np.ndarray:
    """Sum of the streaks' β per pixel, clipped to 1 (a pixel's exposure is finite).

    Each streak is rasterised DDA-style, one sample per pixel along its major axis,
    and ``width`` such lines side by side along its minor axis.

    Returns
    -------
    ndarray float32 (H, W)
    """
    H, W = shape
    if len(beta) and width.max() > 1:
        u0, v0, u1, v1, beta = _widen(u0, v0, u1, v1, width, beta)
    du, dv = u1 - u0, v1 - v0
    n = np.ceil(np.maximum(np.abs(du), np.abs(dv))).astype(np.int64) + 1
    total = int(n.sum())
    if total == 0:
        return np.zeros(shape, dtype=np.float32)
    owner = np.repeat(np.arange(len(n)), n)
    t = (np.arange(total) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(np.maximum(n - 1, 1), n)
    iu = np.rint(u0[owner] + t * du[owner]).astype(np.int64)
    iv = np.rint(v0[owner] + t * dv[owner]).astype(np.int64)
    inside = (iu >= 0) & (iu < W) & (iv >= 0) & (iv < H)
    acc = np.bincount((iv * W + iu)[inside], weights=beta[owner][inside], minlength=H * W)
    acc = acc.astype(np.float32).reshape(H, W)
    return cv2.min(acc, 1.0, dst=acc)


def blend(lin: np.ndarray, beta: np.ndarray, radiance: np.ndarray) -> None:
    """Paper eq. 19 in place: ``I = β·I_E + (1 − β)·I``.

    Parameters
    ----------
    lin : ndarray float32 (H, W, 3)
        Background radiance I_b, overwritten.
    beta : ndarray float32 (H, W)
        Blending weight β per pixel (from :func:`splat_streaks`).
    radiance : ndarray (3,)
        Particle radiance I_E (linear).
    """
    d = cv2.subtract(lin, rgb_scalar(radiance))
    d *= cv2.cvtColor(beta, cv2.COLOR_GRAY2RGB)
    lin -= d


def wind_in_ego(speed_m_s: float, dir_deg: float, heading_rad: float) -> np.ndarray:
    """World wind (speed, heading it blows towards) as ego (forward, right) m/s."""
    phi = math.radians(dir_deg) - heading_rad
    return np.array([speed_m_s * math.cos(phi), speed_m_s * math.sin(phi)])


class ParticleModel(NoiseModel):
    """The ``particles`` stage shared by rain and snow.

    Subclasses provide ``_sample(geom) -> ParticleField``, ``_radiance(state)`` (the
    particles' linear RGB, (3,)) and ``_has_particles()``; their params carry
    ``wind_m_s``, ``wind_dir_deg`` and ``exposure_s``. The field is drawn at the first
    frame (from the model's generator) and then advanced by ``ctx.dt`` every frame.
    """

    def _on_reset(self) -> None:
        self.field: ParticleField | None = None
        self._field_config = None

    def _sample(self, geom: ViewGeometry) -> ParticleField:  # pragma: no cover - abstract
        raise NotImplementedError

    def _radiance(self, state: FrameState) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _has_particles(self) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def particles(self, state: FrameState) -> None:
        if not self._has_particles():
            return
        p, ctx = self.params, state.ctx
        geom = view_geometry(state.camera)
        motion = dict(
            wind_ego=wind_in_ego(p.wind_m_s, p.wind_dir_deg, state.camera.pose[2]),
            speed=ctx.ego_speed,
            yaw_rate=ctx.ego_yaw_rate,
        )
        if self.field is None or self._field_config != geom.config:
            self.field = self._sample(geom)
            self._field_config = geom.config
        else:
            advance(self.field, ctx.dt, forward_m=geom.forward_m, time_s=ctx.time_s, **motion)
        seg = streaks(self.field, geom, exposure_s=p.exposure_s, time_s=ctx.time_s, **motion)
        blend(state.lin, splat_streaks(*seg, state.shape), self._radiance(state))
