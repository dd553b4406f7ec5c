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
from simroad.camera.profile import CameraProfile
from simroad.core.names import PROFILES
from simroad.core.validation import check_choice, normalize_rng

__all__ = ["ROADSIDE_KINDS", "SHOULDER_KINDS", "Palette", "draw_palette"]

#: Gloss of fresh asphalt's binder (aged asphalt: down to half of it).
_SHEEN_RANGE = (0.1, 0.4)

#: Roadside materials a palette can use (``dirt`` is dry soil, ``pavement`` concrete).
ROADSIDE_KINDS = ("grass", "dirt", "gravel", "pavement")
#: Rural shoulder materials (``asphalt``: a paved shoulder, older than the lanes).
SHOULDER_KINDS = ("asphalt", "gravel", "dirt", "concrete")
#: How often each shoulder kind is drawn: most rural roads in service have paved or
#: gravel shoulders (FHWA, Highway Statistics, shoulder type by functional class).
_SHOULDER_P = {"asphalt": 0.4, "gravel": 0.3, "dirt": 0.2, "concrete": 0.1}
#: Factor range of the soiling of the ground beside the lanes (shoulders, kerbs).
_SOILING = (0.6, 0.9)
#: Range of the sky-view factor of a street's sidewalk relative to its carriageway's:
#: beside the facades a wall hides half the sky. In a canyon of height-to-width
#: ``r``, a ground point a share ``f`` of the width from a wall sees the sky's share
#: ``(sin atan(f / r) + sin atan((1 - f) / r)) / 2`` of diffuse light (Oke 1987,
#: ch. 8; Johnson & Watson 1984): at ``f = 0.1`` that is 0.76 (``r = 0.5``) to 0.95
#: (``r = 2``) of the street centre's. Rural roadsides are open: 1.
_SIDEWALK_SKY_VIEW = (0.76, 0.95)
#: Sidewalk materials: tarmac footways are most common in the UK and much of Europe,
#: concrete slabs and poured concrete the rest (Department for Transport, Footway
#: and Cycle Route Design, Construction and Maintenance Guide, 2003).
_SIDEWALK_P = {"asphalt": 0.45, "concrete_aged": 0.4, "concrete": 0.15}

# Roadside kind weights of a rural road: mostly vegetated verges (grass, weeds,
# hedge bottoms), which are dark in the visible; bare soil, gravel or pavement less.
_RURAL_ROADSIDE_P = {"grass": 0.6, "dirt": 0.15, "gravel": 0.15, "pavement": 0.1}
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
    sheen: float  # share of smooth binder reflecting the sky (:mod:`simroad.camera._sheen`)
    shoulder_width_m: float
    kerb_width_m: float = 0.0
    sidewalk_width_m: float = 0.0
    sidewalk_kind: str = "concrete_aged"  # asphalt, concrete_aged or concrete

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


def aggregate_hue(albedo: np.ndarray, brown: float) -> np.ndarray:
    """Aged asphalt of a world whose aggregate is ``brown`` (0-1) of the way from grey
    to brown: the albedo's chroma about its mean, scaled by ``brown``.

    Worn asphalt takes the colour of the aggregate the binder wears off (Herold &
    Roberts 2005): brown where it is a local sandstone or flint gravel (the measured
    R/G ~ G/B ~ 1.2 of :data:`~simroad.camera.materials.ALBEDO`'s ``asphalt_aged``),
    grey where it is granite, basalt or limestone, the common road stones."""
    grey = float(np.mean(albedo))
    return (grey + float(brown) * (np.asarray(albedo, np.float32) - grey)).astype(np.float32)


def _shoulder_albedo(kind: str, rng: np.random.Generator, asphalt_scale: float, brown: float) -> np.ndarray:
    """A shoulder's albedo, soiled: tyre- and road-wear particles, brake dust and soot
    settle within a few metres of the traffic (Kole et al. 2017, Int. J. Environ. Res.
    Public Health 14:1265) and darken what lies beside the lanes by 10-40 %."""
    if kind == "asphalt":  # older than the lanes, untrafficked: no polish
        base = aggregate_hue(draw_albedo("asphalt_aged", rng), brown) * asphalt_scale
    else:
        base = draw_albedo({"gravel": "gravel", "dirt": "soil", "concrete": "concrete_aged"}[kind], rng)
    return np.clip(base * rng.uniform(*_SOILING), 0.0, 1.0)


def _choice(weights: dict[str, float], rng: np.random.Generator) -> str:
    p = np.array(list(weights.values()))
    return str(rng.choice(list(weights), p=p / p.sum()))


def draw_palette(
    rng: np.random.Generator | int,
    roadside: str | None = None,
    *,
    profile: str = "rural",
    camera_profile: CameraProfile | None = None,
) -> Palette:
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
    camera_profile : CameraProfile, optional
        Its ``aged_share`` (the share of worn asphalt) and ``asphalt_scale`` (a factor
        on the asphalt's albedo); simroad's default when None.

    Returns
    -------
    Palette
    """
    rng = normalize_rng(rng)
    check_choice("profile", profile, PROFILES)
    if roadside is not None:
        check_choice("roadside", roadside, ROADSIDE_KINDS)
    cp = camera_profile if camera_profile is not None else CameraProfile()
    # Drawn first: the binder's gloss, highest on fresh asphalt, lower as the aggregate is exposed.
    gloss = float(rng.uniform(*_SHEEN_RANGE))
    brown = float(rng.random())  # the region's aggregate, grey (0) to brown (1)
    aged = rng.random() < cp.aged_share
    age = float(rng.uniform(0.45, 1.0) if aged else rng.uniform(0.0, 0.3))
    fresh, old = draw_albedo("asphalt_fresh", rng), aggregate_hue(draw_albedo("asphalt_aged", rng), brown)
    sheen = gloss * (1.0 - 0.5 * age)
    asphalt = np.clip((fresh + min(1.0, age * 1.25) * (old - fresh)) * cp.asphalt_scale, 0.0, 1.0)
    patch = (
        draw_albedo("asphalt_fresh", rng)
        if rng.random() < 0.7
        else aggregate_hue(draw_albedo("asphalt_aged", rng), brown)
    )
    patch = np.clip(patch * cp.asphalt_scale, 0.0, 1.0)
    if profile == "urban":
        p = np.array([_URBAN_ROADSIDE_P[k] for k in ROADSIDE_KINDS])
        kind = roadside or str(rng.choice(ROADSIDE_KINDS, p=p / p.sum()))
    else:
        kind = roadside or _choice(_RURAL_ROADSIDE_P, rng)
    rs, rs_alt = _roadside_albedos(kind, rng)
    shoulder = _choice(_SHOULDER_P, rng)
    sh = _shoulder_albedo(shoulder, rng, cp.asphalt_scale, brown)
    kerb = draw_albedo("kerb_stone", rng) * rng.uniform(*_SOILING)
    walk = _choice(_SIDEWALK_P, rng)
    if walk == "asphalt":
        sidewalk = aggregate_hue(draw_albedo("asphalt_aged", rng), brown) * cp.asphalt_scale
    else:
        sidewalk = draw_albedo(walk, rng)
    sidewalk = np.clip(sidewalk * rng.uniform(*_SOILING), 0.0, 1.0)
    if profile == "urban":  # beside the facades: less of the sky's light
        shade = rng.uniform(*_SIDEWALK_SKY_VIEW)
        sidewalk, kerb = sidewalk * shade, kerb * shade
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
        sidewalk_kind=walk,
        asphalt_age=age,
        marking_wear=float(rng.uniform(0.0, 0.6) * (0.4 + age)),
        sheen=sheen,
        shoulder_width_m=0.0 if urban else float(rng.uniform(0.5, 2.5)),
        kerb_width_m=float(rng.uniform(0.15, 0.3)) if urban else 0.0,
        sidewalk_width_m=float(rng.uniform(1.5, 4.0)) if urban else 0.0,
    )
