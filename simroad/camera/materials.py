"""Measured reflectances of the world's surfaces, and per-world draws within them.

Every surface the camera sees (ground, scenery, car paint) takes its linear RGB
albedo from :data:`ALBEDO`: a range per material, from published measurements
(docs/materials.md lists the sources). A world draws one value per material within
its range (:func:`draw_albedo`), so worlds differ as real places do.

(First version: ranges to be refined against the sources in docs/materials.md.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simroad._validation import check_choice

__all__ = ["ALBEDO", "AlbedoRange", "draw_albedo"]


@dataclass(frozen=True)
class AlbedoRange:
    """Linear RGB albedo range of one material.

    ``lo`` and ``hi`` bound the per-channel albedo; a draw interpolates between them
    with one shared parameter (brightness) plus a small per-channel tint.
    """

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    tint: float = 0.03  # relative per-channel jitter
    source: str = ""


ALBEDO: dict[str, AlbedoRange] = {
    "asphalt_fresh": AlbedoRange((0.04, 0.04, 0.04), (0.07, 0.07, 0.07)),
    "asphalt_aged": AlbedoRange((0.09, 0.09, 0.08), (0.18, 0.17, 0.16)),
    "marking": AlbedoRange((0.45, 0.45, 0.43), (0.75, 0.75, 0.72)),
    "concrete": AlbedoRange((0.20, 0.20, 0.19), (0.40, 0.40, 0.38)),
    "kerb_stone": AlbedoRange((0.18, 0.18, 0.17), (0.35, 0.35, 0.33)),
    "grass": AlbedoRange((0.04, 0.07, 0.03), (0.09, 0.14, 0.05), tint=0.06),
    "soil": AlbedoRange((0.10, 0.08, 0.06), (0.25, 0.20, 0.15)),
    "gravel": AlbedoRange((0.12, 0.12, 0.11), (0.28, 0.27, 0.25)),
    "snow": AlbedoRange((0.75, 0.78, 0.82), (0.92, 0.94, 0.96), tint=0.01),
    "foliage": AlbedoRange((0.03, 0.05, 0.02), (0.07, 0.11, 0.04), tint=0.08),
    "bark": AlbedoRange((0.06, 0.05, 0.04), (0.15, 0.12, 0.09)),
    "brick": AlbedoRange((0.15, 0.08, 0.06), (0.35, 0.20, 0.14)),
    "plaster": AlbedoRange((0.30, 0.29, 0.27), (0.70, 0.68, 0.64), tint=0.05),
    "galvanised_steel": AlbedoRange((0.25, 0.25, 0.26), (0.45, 0.45, 0.46)),
    "glass": AlbedoRange((0.03, 0.035, 0.04), (0.06, 0.065, 0.07)),
    "tyre": AlbedoRange((0.02, 0.02, 0.02), (0.04, 0.04, 0.04)),
}


def draw_albedo(name: str, rng: np.random.Generator) -> np.ndarray:
    """One world's albedo of material ``name``: float32 (3,), linear RGB in [0, 1]."""
    check_choice("material", name, tuple(ALBEDO))
    r = ALBEDO[name]
    lo, hi = np.asarray(r.lo), np.asarray(r.hi)
    t = rng.random()
    tint = 1.0 + rng.normal(0.0, r.tint, size=3)
    return np.clip((lo + t * (hi - lo)) * tint, 0.0, 1.0).astype(np.float32)
