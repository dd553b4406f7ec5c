"""World-anchored periodic textures of the ground materials, from their albedos.

Each material of a :class:`~simroad.camera.palette.Palette` becomes a square tile
that wraps seamlessly (so any window of the world samples it consistently): albedo
maps built in linear RGB (grain, blotches, patches, joints), lit by the clear-
weather sky (:func:`simroad.camera.lighting.radiance`) and gamma-encoded to sRGB
uint8 (:func:`simroad.core.radiometry.linear_to_srgb`).
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from simroad.camera.lighting import radiance
from simroad.camera.palette import Palette
from simroad.core.radiometry import GAMMA, linear_to_srgb
from simroad.core.validation import normalize_rng

__all__ = ["ground_textures", "periodic_noise", "wear_factor"]

_CRACK_ALBEDO = 0.035  # bitumen crack sealant


def periodic_noise(size: int, scale_px: float, rng: np.random.Generator | int) -> np.ndarray:
    """Smooth periodic Gaussian noise, float32 (size, size), zero mean, unit std.

    White noise low-passed in the Fourier domain with a Gaussian of standard
    deviation ``scale_px`` texels, so the tile wraps seamlessly.
    """
    rng = normalize_rng(rng)
    white = rng.standard_normal((size, size), dtype=np.float32)
    # rfft2 as its two passes (rows, then columns): the same transform, bit for bit,
    # five times faster than numpy's rfftn for this size.
    spectrum = np.fft.fft(np.fft.rfft(white, axis=1), axis=0)  # complex64
    out = np.fft.irfft2(spectrum * _lowpass(size, float(scale_px)), s=(size, size))
    out /= out.std() + 1e-12
    return out.astype(np.float32)


@functools.lru_cache(maxsize=32)
def _lowpass(size: int, scale_px: float) -> np.ndarray:
    """The Gaussian low-pass of :func:`periodic_noise` on the rfft2 grid (read-only)."""
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.rfftfreq(size)[None, :]
    lowpass = np.exp(-(fx**2 + fy**2) * (scale_px**2) * 2.0 * np.pi**2)
    lowpass[0, 0] = 0.0
    lowpass.flags.writeable = False
    return lowpass


def _white(size: int, rng: np.random.Generator, channels: int = 1) -> np.ndarray:
    """Unit-variance zero-mean per-texel noise (uniform: three times faster than normal)."""
    shape = (size, size) if channels == 1 else (size, size, channels)
    u = rng.random(shape, dtype=np.float32)
    u -= np.float32(0.5)
    u *= np.float32(math.sqrt(12.0))
    return u


def _smoothstep(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return (t * t * (3.0 - 2.0 * t)).astype(np.float32)


def _grain(base, size: int, rng: np.random.Generator, lum: float, chroma: float) -> np.ndarray:
    """``base`` albedo (3,) with per-texel luminance and per-channel grain, (size, size, 3)."""
    light = _white(size, rng)
    light *= np.float32(lum)
    light += np.float32(1.0)
    g = _white(size, rng, 3)
    g *= np.float32(chroma)
    g += light[..., None]
    np.maximum(g, np.float32(0.2), out=g)
    g *= np.asarray(base, dtype=np.float32)
    return g


def _draw_wrapped(canvas: np.ndarray, polys: list[np.ndarray], value: float, *, fill: bool, thickness: int = 1) -> None:
    """Draw polylines/polygons (texel coordinates) on a periodic canvas, wrapping."""
    size = canvas.shape[0]
    for p in polys:
        for dy in (-size, 0, size):
            for dx in (-size, 0, size):
                q = np.round((p + (dx, dy)) * 16).astype(np.int32)
                if fill:
                    cv2.fillPoly(canvas, [q], value, lineType=cv2.LINE_AA, shift=4)
                else:
                    cv2.polylines(canvas, [q], False, value, thickness, lineType=cv2.LINE_AA, shift=4)


def _patch_mask(size: int, texel_m: float, rng: np.random.Generator, count: int) -> np.ndarray:
    """Rectangular repair patches (1-4 m x 1-3 m, any orientation): float32 mask in [0, 1]."""
    mask = np.zeros((size, size), dtype=np.float32)
    polys = []
    for _ in range(count):
        c = rng.uniform(0, size, 2)
        w, h = rng.uniform(1.0, 4.0) / texel_m, rng.uniform(1.0, 3.0) / texel_m
        a = rng.uniform(0, math.pi)
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        corners = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2.0 @ R.T + c
        polys.append(corners)
    _draw_wrapped(mask, polys, 1.0, fill=True)
    return mask


def _crack_mask(size: int, texel_m: float, rng: np.random.Generator, count: int) -> np.ndarray:
    """Meandering sealed cracks (random walks of 3-15 m): float32 mask in [0, 1]."""
    mask = np.zeros((size, size), dtype=np.float32)
    polys = []
    for _ in range(count):
        n = int(rng.uniform(3.0, 15.0) / 0.3)
        heading = rng.uniform(0, 2 * math.pi) + np.cumsum(rng.normal(0.0, 0.25, n))
        steps = 0.3 / texel_m * np.column_stack([np.cos(heading), np.sin(heading)])
        polys.append(rng.uniform(0, size, 2) + np.cumsum(steps, axis=0))
    _draw_wrapped(mask, polys, 1.0, fill=False)
    return mask


def _asphalt(p: Palette, size: int, texel_m: float, rng: np.random.Generator) -> np.ndarray:
    age = p.asphalt_age
    tone = 1.0 + 0.07 * periodic_noise(size, 4.0 / texel_m, rng) + 0.04 * periodic_noise(size, 0.6 / texel_m, rng)
    alb = _grain(p.asphalt, size, rng, lum=0.06 + 0.08 * age, chroma=0.01 + 0.01 * age) * tone[..., None]
    # Wear exposes the aggregate unevenly: its stones (grey limestone and granite, dark
    # basalt) show in decimetre-scale blotches, lighter or darker by several percent and
    # only faintly tinted: the stones differ far more in lightness than in hue.
    blotch = 0.03 + 0.07 * age
    light = periodic_noise(size, 0.25 / texel_m, rng)[..., None]
    hue = np.stack([periodic_noise(size, 0.25 / texel_m, rng) for _ in range(3)], axis=-1)
    alb *= 1.0 + blotch * (light + 0.2 * hue)
    patches = _patch_mask(size, texel_m, rng, int(rng.poisson(1.0 + 6.0 * age)))[..., None]
    alb += patches * (_grain(p.asphalt_patch, size, rng, lum=0.06, chroma=0.03) * tone[..., None] - alb)
    cracks = 0.6 * _crack_mask(size, texel_m, rng, int(rng.poisson(12.0 * age * age)))[..., None]
    alb += cracks * (_CRACK_ALBEDO - alb)
    return alb


def _marking(p: Palette, asphalt: np.ndarray, size: int, texel_m: float, rng: np.random.Generator) -> np.ndarray:
    paint = _grain(p.marking, size, rng, lum=0.05, chroma=0.015)
    worn = _smoothstep(
        periodic_noise(size, 0.8 / texel_m, rng) + 0.6 * _white(size, rng), 1.5 - 3.0 * p.marking_wear, 2.5
    )
    return paint + (0.25 + 0.75 * worn[..., None]) * worn[..., None] * (asphalt - paint)


def _vegetated(base, alt, size: int, texel_m: float, rng: np.random.Generator, cover: float) -> np.ndarray:
    """Grass-like: clumps and blades, with patches of ``alt`` covering about ``cover``."""
    field = periodic_noise(size, 2.5 / texel_m, rng) + 0.5 * periodic_noise(size, 0.6 / texel_m, rng)
    thr = float(np.quantile(field, 1.0 - cover))
    m = _smoothstep(field, thr - 0.3, thr + 0.3)[..., None]
    clumps = 1.0 + 0.15 * periodic_noise(size, 0.3 / texel_m, rng)[..., None]
    a = _grain(base, size, rng, lum=0.22, chroma=0.10) * clumps
    b = _grain(alt, size, rng, lum=0.18, chroma=0.06) * clumps
    return a + m * (b - a)


def _soil(base, wet, size: int, texel_m: float, rng: np.random.Generator) -> np.ndarray:
    m = _smoothstep(periodic_noise(size, 3.0 / texel_m, rng), 0.4, 1.4)[..., None]
    alb = _grain(base, size, rng, lum=0.12, chroma=0.04)
    alb += m * (_grain(wet, size, rng, lum=0.10, chroma=0.04) - alb)
    stones = (rng.random((size, size)) < 0.02)[..., None]
    return np.where(stones, alb * 1.8, alb) * (1.0 + 0.08 * periodic_noise(size, 1.0 / texel_m, rng))[..., None]


def _gravel(base, weeds, size: int, texel_m: float, rng: np.random.Generator, cover: float) -> np.ndarray:
    tone = 1.0 + 0.08 * periodic_noise(size, 2.0 / texel_m, rng)[..., None]
    alb = _grain(base, size, rng, lum=0.2, chroma=0.03) * tone
    if cover > 0:
        field = periodic_noise(size, 0.7 / texel_m, rng)
        m = _smoothstep(field, float(np.quantile(field, 1.0 - cover)), float(np.quantile(field, 1.0 - cover / 3)))
        alb += m[..., None] * (_grain(weeds, size, rng, lum=0.25, chroma=0.1) - alb)
    return alb


def _concrete(base, size: int, texel_m: float, rng: np.random.Generator, slab_m: float | None) -> np.ndarray:
    """Concrete, optionally in square slabs of about ``slab_m`` with dark joints."""
    stains = 1.0 + 0.07 * periodic_noise(size, 1.5 / texel_m, rng) + 0.03 * periodic_noise(size, 0.3 / texel_m, rng)
    alb = _grain(base, size, rng, lum=0.05, chroma=0.015) * stains[..., None]
    if slab_m is None:
        return alb
    n = 1 << max(1, round(math.log2(slab_m / texel_m)))  # a power of two: the tile wraps
    n = min(n, size)
    idx = np.arange(size) // n
    per_slab = 1.0 + 0.05 * rng.standard_normal((size // n, size // n)).astype(np.float32)
    alb *= per_slab[idx[:, None], idx[None, :]][..., None]
    joint = (np.arange(size) % n) == 0
    alb[joint, :] *= 0.6
    alb[:, joint] *= 0.6
    return alb


def _kerb(base, size: int, texel_m: float, rng: np.random.Generator) -> np.ndarray:
    tone = 1.0 + 0.05 * periodic_noise(size, 1.0 / texel_m, rng)[..., None]
    return _grain(base, size, rng, lum=0.12, chroma=0.05) * tone  # granite speckle


def _encode(albedo: np.ndarray) -> np.ndarray:

    return linear_to_srgb(radiance(np.clip(albedo, 0.0, 1.0).astype(np.float32)))


def ground_textures(
    palette: Palette, size: int, texel_m: float, rng: np.random.Generator | int
) -> dict[str, np.ndarray]:
    """The world's ground textures: name -> uint8 (size, size, 3) sRGB, periodic.

    Names: ``roadside``, ``shoulder``, ``asphalt``, ``marking``, ``kerb``,
    ``sidewalk`` (the last two only for the urban profile). ``size`` is in texels of
    ``texel_m`` metres.
    """
    rng = normalize_rng(rng)
    p = palette
    asphalt = _asphalt(p, size, texel_m, rng)
    out = {"asphalt": asphalt, "marking": _marking(p, asphalt, size, texel_m, rng)}
    if p.roadside == "grass":
        out["roadside"] = _vegetated(
            p.roadside_albedo, p.roadside_alt, size, texel_m, rng, float(rng.uniform(0.1, 0.4))
        )
    elif p.roadside == "dirt":
        out["roadside"] = _soil(p.roadside_albedo, p.roadside_alt, size, texel_m, rng)
    elif p.roadside == "gravel":
        out["roadside"] = _gravel(p.roadside_albedo, p.roadside_alt, size, texel_m, rng, float(rng.uniform(0.0, 0.2)))
    else:
        out["roadside"] = _concrete(p.roadside_albedo, size, texel_m, rng, float(rng.uniform(2.5, 4.0)))
    if p.profile == "urban":
        out["kerb"] = _kerb(p.kerb, size, texel_m, rng)
        slab = float(rng.uniform(1.4, 2.2))
        out["sidewalk"] = _concrete(p.sidewalk, size, texel_m, rng, None if p.sidewalk_kind == "asphalt" else slab)
    elif p.shoulder == "gravel":
        out["shoulder"] = _gravel(p.shoulder_albedo, p.roadside_alt, size, texel_m, rng, 0.0)
    elif p.shoulder == "dirt":
        out["shoulder"] = _soil(p.shoulder_albedo, np.asarray(p.shoulder_albedo) * 0.6, size, texel_m, rng)
    else:
        out["shoulder"] = _concrete(p.shoulder_albedo, size, texel_m, rng, None)
    return {k: _encode(v) for k, v in out.items()}


def wear_factor(distance_m: np.ndarray, age: float) -> np.ndarray:
    """Multiplicative sRGB factor of asphalt wear across a lane, float32 like ``distance_m``.

    ``distance_m`` is the distance inside the road to the nearest lane edge (the
    world's signed distance field, >= 0 on the road). Wheel paths (about 1.2 m in
    from the edge of a 3.5-4 m lane) are polished lighter on old asphalt and
    darkened by tyre rubber on new; the lane centre (2 m in) carries a dark stripe
    of oil drips.
    """
    d = np.asarray(distance_m, dtype=np.float32)
    wheel = np.exp(-(((d - 1.2) / 0.35) ** 2))
    oil = np.exp(-(((d - 2.0) / 0.3) ** 2))
    lin = 1.0 + (0.16 * age - 0.05) * wheel - (0.04 + 0.10 * age) * oil
    return np.power(lin, 1.0 / GAMMA).astype(np.float32)
