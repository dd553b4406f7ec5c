"""One world's ground materials: which surfaces, their measured albedos, band widths.

A palette is drawn per world from the episode's generator: the asphalt (fresh or
aged, with its repair patches), the paint, the roadside kind and, for the cross-
section, either a rural shoulder (gravel, soil or concrete) or an urban kerb and
sidewalk. Albedos come from :mod:`simroad.camera.materials` (linear RGB); the world
raster turns them into textured sRGB texels (:mod:`simroad.camera.textures`).
Nothing keeps the road darker or greyer than its surroundings: real roadsides can be
as grey and as dark as the road.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simroad.camera.materials import draw_albedo
from simroad.core.names import PROFILES
from simroad.core.validation import check_choice, normalize_rng

__all__ = ["ROADSIDE_KINDS", "SHOULDER_KINDS", "Palette", "draw_palette"]

#: Roadside materials a palette can use (``dirt`` is dry soil, ``pavement`` concrete).
ROADSIDE_KINDS = ("grass", "dirt", "gravel", "pavement")
#: Rural shoulder materials.
SHOULDER_KINDS = ("gravel", "dirt", "concrete")

# Probability that a world's road is aged asphalt (most roads in service are).
_P_AGED = 0.8
# Roadside kind weights of an urban street (a verge beyond the sidewalk).
_URBAN_ROADSIDE_P = {"grass": 0.35, "dirt": 0.1, "gravel": 0.15, "pavement": 0.4}


@dataclass(frozen=True)
class Palette:
    """The ground materials of one world.

    Albedos are linear RGB float triples in [0, 1] (see :mod:`simroad.camera.materials`);
    widths are in metres measured outward from the road edge.

    Attributes
    ----------
    profile : str
        ``rural`` or ``urban`` (see :data:`PROFILES`).
    roadside, shoulder : str
        Roadside kind (:data:`ROADSIDE_KINDS`) and shoulder kind (:data:`SHOULDER_KINDS`).
    asphalt_age : float
        0 = freshly laid, 1 = old and worn; sets the asphalt between its fresh and
        aged albedo and the amount of patches, cracks and wheel-track polish.
    shoulder_width_m : float
        Rural shoulder width (0 for ``urban``).
    kerb_width_m, sidewalk_width_m : float
        Urban kerb and sidewalk widths (0 for ``rural``).
    """

    profile: str
    roadside: str
    shoulder: str
    asphalt: tuple[float, float, float]
    asphalt_patch: tuple[float, float, float]
    marking: tuple[float, float, float]
    shoulder_albedo: tuple[float, float, float]
    roadside_albedo: tuple[float, float, float]
    roadside_alt: tuple[float, float, float]  # patches in the roadside (dry grass, wet soil, weeds)
    kerb: tuple[float, float, float]
    sidewalk: tuple[float, float, float]
    asphalt_age: float
    marking_wear: float  # 0 = fresh paint, 1 = mostly worn off
    shoulder_width_m: float
    kerb_width_m: float = 0.0
    sidewalk_width_m: float = 0.0

    @property
    def verge_width_m(self) -> float:
        """Width (m) of the bands between the road edge and the roadside."""
        return self.shoulder_width_m + self.kerb_width_m + self.sidewalk_width_m


def _t(a: np.ndarray) -> tuple[float, float, float]:
    r, g, b = (float(v) for v in a)
    return (r, g, b)


def _roadside_albedos(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Main and patch albedo of a roadside kind."""
    if kind == "grass":
        return draw_albedo("grass", rng), draw_albedo("grass_dry" if rng.random() < 0.6 else "soil", rng)
    if kind == "dirt":
        return draw_albedo("soil", rng), draw_albedo("soil_wet", rng)
    if kind == "gravel":
        return draw_albedo("gravel", rng), draw_albedo("grass", rng)  # weeds
    return draw_albedo("concrete_aged" if rng.random() < 0.6 else "concrete", rng), draw_albedo("concrete_aged", rng)


def _shoulder_albedo(kind: str, rng: np.random.Generator) -> np.ndarray:
    return draw_albedo({"gravel": "gravel", "dirt": "soil", "concrete": "concrete_aged"}[kind], rng)


def draw_palette(rng: np.random.Generator | int, roadside: str | None = None, *, profile: str = "rural") -> Palette:
    """Draw the ground materials of one world from ``rng``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The world's generator.
    roadside : str, optional
        Force the roadside kind (one of :data:`ROADSIDE_KINDS`); drawn when omitted.
    profile : str
        ``rural`` (shoulder 0.5-2.5 m, then the roadside) or ``urban`` (kerb
        0.15-0.3 m and sidewalk 1.5-4 m, then the roadside).

    Returns
    -------
    Palette
    """
    rng = normalize_rng(rng)
    check_choice("profile", profile, PROFILES)
    if roadside is not None:
        check_choice("roadside", roadside, ROADSIDE_KINDS)
    aged = rng.random() < _P_AGED
    age = float(rng.uniform(0.45, 1.0) if aged else rng.uniform(0.0, 0.3))
    fresh, old = draw_albedo("asphalt_fresh", rng), draw_albedo("asphalt_aged", rng)
    asphalt = fresh + min(1.0, age * 1.25) * (old - fresh)
    patch = draw_albedo("asphalt_fresh", rng) if rng.random() < 0.7 else draw_albedo("asphalt_aged", rng)
    if profile == "urban":
        p = np.array([_URBAN_ROADSIDE_P[k] for k in ROADSIDE_KINDS])
        kind = roadside or str(rng.choice(ROADSIDE_KINDS, p=p / p.sum()))
    else:
        kind = roadside or str(rng.choice(ROADSIDE_KINDS))
    rs, rs_alt = _roadside_albedos(kind, rng)
    shoulder = str(rng.choice(SHOULDER_KINDS))
    sh = _shoulder_albedo(shoulder, rng)
    kerb = draw_albedo("kerb_stone", rng)
    sidewalk = draw_albedo("concrete_aged" if rng.random() < 0.7 else "concrete", rng)
    urban = profile == "urban"
    return Palette(
        profile=profile,
        roadside=kind,
        shoulder=shoulder,
        asphalt=_t(asphalt),
        asphalt_patch=_t(patch),
        marking=_t(draw_albedo("marking", rng)),
        shoulder_albedo=_t(sh),
        roadside_albedo=_t(rs),
        roadside_alt=_t(rs_alt),
        kerb=_t(kerb),
        sidewalk=_t(sidewalk),
        asphalt_age=age,
        marking_wear=float(rng.uniform(0.0, 0.6) * (0.4 + age)),
        shoulder_width_m=0.0 if urban else float(rng.uniform(0.5, 2.5)),
        kerb_width_m=float(rng.uniform(0.15, 0.3)) if urban else 0.0,
        sidewalk_width_m=float(rng.uniform(1.5, 4.0)) if urban else 0.0,
    )
