"""Measured reflectances of the world's surfaces, and per-world draws within them.

Every surface the camera sees (ground, scenery, car paint) takes its linear RGB
albedo from :data:`ALBEDO`: a range per material from published measurements
(docs/materials.md has the table, the sources and how the RGB values were read from
spectra). A world draws one value per material within its range
(:func:`draw_albedo`), so worlds differ as real places do.

RGB albedos are hemispherical reflectances averaged over three visible bands
(B 420-490 nm, G 500-570 nm, R 590-680 nm); they are *not* the broadband (solar)
albedos of climate tables, which include the near infrared (grass and foliage are
bright there and dark in the visible).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simroad.core.validation import check_choice, normalize_rng

__all__ = ["ALBEDO", "AlbedoRange", "draw_albedo"]


@dataclass(frozen=True)
class AlbedoRange:
    """Linear RGB albedo range of one material.

    ``lo`` and ``hi`` bound the per-channel albedo; a draw interpolates between them
    with one shared parameter (brightness) plus a small per-channel tint (relative
    standard deviation ``tint``). ``source`` names the measurement it rests on.
    """

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    tint: float = 0.03  # relative per-channel jitter
    source: str = ""


_HEROLD = "Herold et al. 2004 (Santa Barbara urban spectral library); Herold & Roberts 2005, Appl. Opt. 44:4327"
_POMERANTZ = "Pomerantz, Akbari & Harvey 2000 (LBNL-45370): new asphalt ~0.05, aged 0.10-0.18"
_LEVINSON = "Levinson & Akbari 2002, Cem. Concr. Res. 32:1679; NCAT/FHWA 2019 Quantifying Pavement Albedo"
_ECOSTRESS = "ECOSTRESS spectral library (Meerdink et al. 2019; ASTER: Baldridge et al. 2009)"
_HOLLAN = "Hollan 2004 (camera-measured asphalt: photopic albedo 0.12-0.15, R/G ~ G/B ~ 1.2)"
_OKE = "Oke 1987, Boundary Layer Climates, Table 1.1"

ALBEDO: dict[str, AlbedoRange] = {
    # Pavements: asphalt brightens and turns brown as the binder wears off the
    # aggregate (reflectance rising from blue to red), concrete darkens with soiling.
    "asphalt_fresh": AlbedoRange((0.042, 0.040, 0.037), (0.067, 0.064, 0.059), 0.02, _POMERANTZ + "; " + _HEROLD),
    "asphalt_aged": AlbedoRange(
        (0.10, 0.085, 0.071), (0.21, 0.178, 0.148), 0.035, _POMERANTZ + "; " + _HEROLD + "; " + _HOLLAN
    ),
    "marking": AlbedoRange(
        (0.30, 0.30, 0.28), (0.62, 0.62, 0.60), 0.02, "EN 1436 Qd classes Q2-Q4 (100-160 mcd m-2 lx-1): rho = pi*Qd"
    ),
    "concrete": AlbedoRange((0.30, 0.30, 0.28), (0.48, 0.47, 0.44), 0.02, _LEVINSON + " (new: 0.35-0.5)"),
    "concrete_aged": AlbedoRange((0.18, 0.18, 0.17), (0.32, 0.31, 0.29), 0.02, _LEVINSON + " (weathered, soiled)"),
    "kerb_stone": AlbedoRange((0.17, 0.17, 0.16), (0.34, 0.33, 0.31), 0.04, _ECOSTRESS + " granite; " + _LEVINSON),
    # Vegetation and soils (visible bands; broadband from Oke 1987).
    "grass": AlbedoRange((0.035, 0.065, 0.025), (0.075, 0.125, 0.045), 0.08, _ECOSTRESS + " grass; " + _OKE),
    "grass_dry": AlbedoRange((0.12, 0.11, 0.06), (0.24, 0.21, 0.11), 0.06, _ECOSTRESS + " dry grass"),
    "soil": AlbedoRange((0.12, 0.095, 0.07), (0.28, 0.22, 0.16), 0.05, _ECOSTRESS + " soils; " + _OKE + " dry soil"),
    "soil_wet": AlbedoRange((0.06, 0.048, 0.036), (0.13, 0.10, 0.075), 0.05, _OKE + " wet soil 0.05-0.15"),
    "gravel": AlbedoRange((0.14, 0.135, 0.12), (0.30, 0.29, 0.26), 0.02, _ECOSTRESS + " granite/limestone chips"),
    "snow": AlbedoRange((0.80, 0.83, 0.86), (0.93, 0.95, 0.97), 0.01, "Warren 1982; Oke 1987: fresh snow 0.8-0.95"),
    "snow_old": AlbedoRange((0.45, 0.46, 0.47), (0.70, 0.71, 0.72), 0.02, "Oke 1987: old snow 0.4-0.7"),
    "foliage": AlbedoRange((0.03, 0.05, 0.02), (0.07, 0.11, 0.04), 0.08, _ECOSTRESS + " broadleaf/conifer"),
    "bark": AlbedoRange((0.06, 0.05, 0.04), (0.15, 0.12, 0.09), 0.05, _ECOSTRESS + " tree bark"),
    "brick": AlbedoRange((0.15, 0.08, 0.06), (0.35, 0.20, 0.14), 0.05, _ECOSTRESS + " red brick; " + _OKE),
    "plaster": AlbedoRange((0.30, 0.29, 0.27), (0.70, 0.68, 0.64), 0.05, _OKE + " white wash/plaster; " + _HEROLD),
    "galvanised_steel": AlbedoRange((0.25, 0.25, 0.26), (0.45, 0.45, 0.46), 0.02, _HEROLD + " (weathered metal)"),
    "glass": AlbedoRange((0.03, 0.035, 0.04), (0.06, 0.065, 0.07), 0.03, "diffuse part only (Fresnel ~0.04)"),
    # A facade's windows seen from the street: at 60-80 degrees of incidence glass
    # reflects 10-40 % (Fresnel, n = 1.52) of the sky and the street it faces, which
    # a Lambertian renderer takes as an apparent albedo of that share of a grey scene.
    "glass_facade": AlbedoRange(
        (0.08, 0.09, 0.10), (0.24, 0.26, 0.28), 0.03, "Fresnel equations, n = 1.52 (Hecht, Optics, ch. 4)"
    ),
    "tyre": AlbedoRange((0.02, 0.02, 0.02), (0.04, 0.04, 0.04), 0.03, "carbon-black rubber, " + _HEROLD),
}


def draw_albedo(name: str, rng: np.random.Generator | int) -> np.ndarray:
    """One world's albedo of material ``name``: float32 (3,), linear RGB in [0, 1].

    Parameters
    ----------
    name : str
        A key of :data:`ALBEDO`.
    rng : numpy.random.Generator
        Draws the brightness within the range and the tint.
    """
    rng = normalize_rng(rng)
    check_choice("material", name, tuple(ALBEDO))
    r = ALBEDO[name]
    lo, hi = np.asarray(r.lo), np.asarray(r.hi)
    t = rng.random()
    tint = 1.0 + rng.normal(0.0, r.tint, size=3)
    return np.clip((lo + t * (hi - lo)) * tint, 0.0, 1.0).astype(np.float32)
