"""Particle streaks in the image: projection, clipping, splatting and the eq. 19 blend.

Photometry (paper eq. 19, Garg & Nayar 2004): during the exposure T a particle's
image, a disc of ``d`` pixels, moves ``L`` pixels. A pixel on its path is covered for
the time it takes the disc to cross it, ``τ = (d + 1)/L·T`` (which is Garg & Nayar's
``τ ≈ 4a/v`` when the disc is one pixel wide), over a fraction ``min(1, d)²`` of its
area, so it blends ``I = β·I_E + (1 − β)·I_b`` with
``β = min(1, d)² · min(1, (d + 1)/L)``. The β of all particles crossing a pixel add.
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad.noise._arrays import rgb_scalar
from simroad.noise._geometry import ViewGeometry
from simroad.noise._particle_field import ParticleField, particle_velocity, relative_velocity

__all__ = ["Streaks", "blend", "splat_streaks", "streaks"]

_Z_NEAR_M = 0.05
_MAX_WIDTH_PX = 15
Streaks = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""``(u0, v0, u1, v1, width, beta)`` of :func:`streaks`, one entry per streak."""
_BETA_MIN = 2e-3  # below a tenth of a grey level on any background: not drawn


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
) -> Streaks:
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
        e = np.zeros(0)
        return e, e, e, e, np.zeros(0, dtype=np.int64), e
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
    sums = np.bincount((iv * W + iu)[inside], weights=beta[owner][inside], minlength=H * W)
    acc = sums.astype(np.float32).reshape(H, W)
    return cv2.min(acc, 1.0, dst=acc)  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands


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
    d = cv2.subtract(lin, rgb_scalar(radiance))  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands
    d *= cv2.cvtColor(beta, cv2.COLOR_GRAY2RGB)
    lin -= d
