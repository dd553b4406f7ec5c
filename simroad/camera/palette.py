"""Surface palettes and world-anchored periodic textures.

Several roadside materials (grass, dirt, gravel, pavement) and asphalt tones are
drawn per episode, so that colour alone does not separate road from off-road.
Textures are periodic tiles, so any window of the world samples them consistently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "ROADSIDE_KINDS",
    "Palette",
    "draw_palette",
    "make_texture",
]

#: Roadside materials a palette can use.
ROADSIDE_KINDS = ("grass", "dirt", "gravel", "pavement")

# Mean RGB colours (0-255) and their per-episode jitter.
_ROADSIDE_RGB = {
    "grass": ((86, 118, 58), 18),
    "dirt": ((132, 108, 80), 16),
    "gravel": ((128, 122, 112), 14),
    "pavement": ((150, 148, 142), 14),
}
_SHOULDER_RGB = {"gravel": ((118, 112, 102), 12), "dirt": ((124, 102, 78), 12)}


@dataclass(frozen=True)
class Palette:
    """Colours (RGB, 0-255) and texture strength of one episode's world."""

    roadside: str
    roadside_rgb: tuple[int, int, int]
    shoulder_rgb: tuple[int, int, int]
    asphalt_rgb: tuple[int, int, int]
    marking_rgb: tuple[int, int, int]
    shoulder_width_m: float
    grain: float  # standard deviation of the texture in colour units


def _rgb(values: np.ndarray) -> tuple[int, int, int]:
    """Three colour values (0-255) as an ``(r, g, b)`` tuple of ints (truncated)."""
    r, g, b = (int(v) for v in values)
    return (r, g, b)


def _jitter(rgb: tuple[int, int, int], amount: float, rng: np.random.Generator) -> tuple[int, int, int]:
    base = np.asarray(rgb, dtype=float)
    shift = rng.normal(0.0, amount) + rng.normal(0.0, amount / 3.0, size=3)
    return _rgb(np.clip(base + shift, 0, 255))


#: Minimum luma difference (0-255) between asphalt and a shoulder or a non-green
#: roadside. Asphalt's albedo is about 0.05-0.10, gravel, concrete and dry soil about
#: 0.2-0.3: real asphalt is always markedly darker than what borders it.
MIN_LUMA_MARGIN = 35.0


def _luma(rgb) -> float:
    r, g, b = (float(v) for v in rgb)
    return 0.299 * r + 0.587 * g + 0.114 * b


def _brighter_than(rgb: tuple[int, int, int], floor: float) -> tuple[int, int, int]:
    """Lift ``rgb`` uniformly until its luma reaches ``floor``."""
    lift = max(0.0, floor - _luma(rgb))
    return _rgb(np.clip(np.asarray(rgb, dtype=float) + lift, 0, 255))


def draw_palette(rng: np.random.Generator, roadside: str | None = None) -> Palette:
    """Draw a palette for one episode from ``rng``; ``roadside`` forces the kind.

    Asphalt is drawn dark grey (luma ~50-85); the shoulder, and a gravel, dirt or
    pavement roadside, are kept at least :data:`MIN_LUMA_MARGIN` brighter (grass is
    told apart by its hue).
    """
    kind = roadside if roadside is not None else str(rng.choice(ROADSIDE_KINDS))
    rs_rgb, rs_j = _ROADSIDE_RGB[kind]
    sh_kind = str(rng.choice(tuple(_SHOULDER_RGB)))
    sh_rgb, sh_j = _SHOULDER_RGB[sh_kind]
    grey = rng.uniform(50, 85)
    tint = rng.normal(0.0, 3.0, size=3)
    asphalt = _rgb(np.clip(grey + tint, 0, 255))
    floor = _luma(asphalt) + MIN_LUMA_MARGIN
    roadside_rgb = _jitter(rs_rgb, rs_j, rng)
    if kind != "grass":
        roadside_rgb = _brighter_than(roadside_rgb, floor)
    return Palette(
        roadside=kind,
        roadside_rgb=roadside_rgb,
        shoulder_rgb=_brighter_than(_jitter(sh_rgb, sh_j, rng), floor),
        asphalt_rgb=asphalt,
        marking_rgb=_jitter((228, 228, 222), 6, rng),
        shoulder_width_m=float(rng.uniform(0.8, 2.0)),
        grain=float(rng.uniform(5.0, 9.0)),
    )


def make_texture(
    rgb: tuple[int, int, int],
    size: int,
    rng: np.random.Generator,
    *,
    grain: float,
    blotch: float,
    blotch_scale_px: float,
) -> np.ndarray:
    """A periodic (size, size, 3) float32 texture around ``rgb``.

    Fine grain (white noise) plus low-frequency blotches, both filtered in the
    Fourier domain so that the tile wraps seamlessly.
    """
    fine = rng.normal(0.0, 1.0, size=(size, size)).astype(np.float32)
    white = rng.normal(0.0, 1.0, size=(size, size))
    f = np.fft.fftfreq(size)
    fx, fy = np.meshgrid(f, f)
    lowpass = np.exp(-((fx**2 + fy**2) * (blotch_scale_px**2) * 2.0 * np.pi**2))
    lowpass[0, 0] = 0.0  # zero mean: the texture stays centred on its palette colour
    coarse = np.real(np.fft.ifft2(np.fft.fft2(white) * lowpass))
    coarse /= coarse.std() + 1e-9
    lum = grain * fine + blotch * coarse.astype(np.float32)
    tex = np.asarray(rgb, dtype=np.float32)[None, None, :] + lum[..., None]
    # A faint per-channel variation keeps textures from being perfectly grey.
    tex += rng.normal(0.0, grain * 0.25, size=(size, size, 3)).astype(np.float32)
    return tex
