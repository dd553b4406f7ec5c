"""The kinds of scenery, each built from convex solids with measured albedos.

Sizes are those of real roadside objects (m): deciduous trees 5-14 m high with
crowns 3-8 m across, conifers 6-16 m; street lights 7-10 m with a 1.2-2.2 m arm over
the road; signs 0.6-1.0 m plates at 2-2.8 m; houses 1-3 floors, town buildings 2-6
floors of 3.0-3.3 m; walls 2-4 m; W-beam guard rails with the beam at 0.45-0.75 m on
posts every 4 m; overpass decks with their underside 5.0-6.5 m above the road.
Every function adds solids to a :class:`SolidBuilder` and returns nothing.
"""

from __future__ import annotations

import math

import numpy as np

from simroad.camera._scenery_solids import CANOPY_TEMPLATES, SolidBuilder, rect
from simroad.camera.codes import BUILDING, GUARDRAIL, OVERPASS, POLE, SIGN, VEGETATION, WALL
from simroad.camera.materials import draw_albedo

__all__ = ["building", "guard_rail", "overpass", "sign", "street_light", "tree", "tree_radius", "wall"]

#: Retroreflective sign sheeting, linear RGB (white, yellow, red, blue, green).
SIGN_FACES = np.array(
    [[0.62, 0.62, 0.60], [0.55, 0.40, 0.03], [0.35, 0.03, 0.03], [0.02, 0.06, 0.30], [0.02, 0.16, 0.06]],
    dtype=np.float32,
)
_FLOOR_M = 3.1


def _square(at: np.ndarray, radius: float, turn: float) -> np.ndarray:
    phi = np.arange(4) * (np.pi / 2) + turn
    return at + radius * np.column_stack([np.cos(phi), np.sin(phi)])


def tree_radius(kind: str, u: float) -> float:
    """Crown radius (m) of a tree of ``kind`` for a uniform draw ``u``."""
    return 1.5 + 2.5 * u if kind == "round" else 1.2 + 1.4 * u


def tree(
    b: SolidBuilder, rng: np.random.Generator, at: np.ndarray, kind: str, radius: float,
    *, crown_bottom_m: float | None = None,
) -> None:  # fmt: skip
    """A trunk (hexagonal prism) and a canopy polyhedron (``kind`` round or cone);
    ``crown_bottom_m`` lifts the crown's lowest point to that height (street trees)."""
    bark = draw_albedo("bark", rng)
    leaf = draw_albedo("foliage", rng)
    verts, faces = CANOPY_TEMPLATES[kind][int(rng.integers(len(CANOPY_TEMPLATES[kind])))]
    yaw = rng.uniform(0, 2 * np.pi)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    if kind == "round":
        trunk_h = rng.uniform(1.8, 3.5)
        scale = np.array([radius, radius, radius * rng.uniform(0.8, 1.25)])
        base = trunk_h + 0.6 * scale[2]
        trunk_top = base
    else:
        leaf = leaf * np.float32(0.75)
        trunk_h = rng.uniform(0.4, 1.5)
        scale = np.array([radius, radius, rng.uniform(2.8, 5.0) * radius])
        base = trunk_h
        trunk_top = trunk_h + 0.3 * scale[2]
    if crown_bottom_m is not None:
        lift = max(0.0, crown_bottom_m - (base + float(verts[:, 2].min()) * scale[2]))
        base, trunk_top = base + lift, trunk_top + lift
    b.prism(_square(at, 0.07 + 0.05 * radius, yaw), 0.0, trunk_top, bark, VEGETATION)
    v = (verts * scale) @ rot.T + np.array([at[0], at[1], base])
    b.polyhedron(v, faces, leaf, VEGETATION, crown=True)


def street_light(
    b: SolidBuilder, rng: np.random.Generator, at: np.ndarray, towards_road: np.ndarray, albedo, *, arm: bool
) -> None:
    """A pole (0.16-0.24 m square) with, if ``arm``, an arm and a lamp head reaching
    towards the road (``towards_road`` a unit (2,) vector)."""
    height = rng.uniform(7.0, 10.0)
    w = rng.uniform(0.16, 0.24)
    heading = math.atan2(towards_road[1], towards_road[0])
    b.prism(rect(at, heading, w, w), 0.0, height, albedo, POLE)
    if arm:
        reach = rng.uniform(1.2, 2.2)
        mid = at + towards_road * (reach / 2)
        b.prism(rect(mid, heading, reach, 0.1), height - 0.15, height, albedo, POLE)
        head = at + towards_road * (reach - 0.25)
        b.prism(rect(head, heading, 0.6, 0.3), height - 0.3, height - 0.12, albedo * np.float32(0.6), POLE)


def sign(b: SolidBuilder, rng: np.random.Generator, at: np.ndarray, facing: float, steel) -> None:
    """A sign: a post and, resting on its top, a plate facing heading ``facing``
    (rad) with a coloured decal as its front."""
    w, h = rng.uniform(0.6, 1.0), rng.uniform(0.6, 1.0)
    z0 = rng.uniform(1.8, 2.2)
    b.prism(rect(at, facing, 0.08, 0.08), 0.0, z0, steel, POLE)
    fp = rect(at, facing, 0.04, w)
    sid = b.prism(fp, z0, z0 + h, steel, SIGN)
    front = np.array([[*fp[0], z0], [*fp[1], z0], [*fp[1], z0 + h], [*fp[0], z0 + h]])
    face = SIGN_FACES[int(rng.integers(len(SIGN_FACES)))]
    b.decal(sid, front, face, SIGN)


def _windows(
    b: SolidBuilder, sid: int, p0: np.ndarray, p1: np.ndarray, floors: int, glass, pitch: float, *, shop: bool
) -> None:  # fmt: skip
    """Windows on the wall from ``p0`` to ``p1`` (ground corners, (2,)): one per
    ``pitch`` m and floor; ``shop``: the ground floor is one shop window."""
    length = float(np.linalg.norm(p1 - p0))
    n = int(length // pitch)
    if n < 1:
        return
    d = (p1 - p0) / length
    wide = 0.45 * pitch
    margin = (length - n * pitch) / 2 + (pitch - wide) / 2
    for f in range(floors):
        z0, z1 = f * _FLOOR_M + 0.9, f * _FLOOR_M + 2.3
        if f == 0 and shop:
            a, c = p0 + d * 0.6, p1 - d * 0.6
            b.decal(sid, np.array([[*a, 0.3], [*c, 0.3], [*c, 2.6], [*a, 2.6]]), glass, BUILDING)
            continue
        for k in range(n):
            a = p0 + d * (margin + pitch * k)
            c = a + d * wide
            b.decal(sid, np.array([[*a, z0], [*c, z0], [*c, z1], [*a, z1]]), glass, BUILDING)


def building(
    b: SolidBuilder, rng: np.random.Generator, footprint: np.ndarray, floors: int, *, shop_front: bool = False
) -> None:  # fmt: skip
    """A building over a convex quadrilateral ``footprint`` (4, 2) with a flat roof
    and rows of windows; ``shop_front``: a town facade whose street face (corners 0
    to 1) alone has windows (its neighbours hide the sides), shops at ground level."""
    kind = ("plaster", "brick", "concrete")[int(rng.choice(3, p=[0.5, 0.3, 0.2]))]
    wall_a = draw_albedo(kind, rng)
    roof = draw_albedo("concrete", rng) * np.float32(0.6)
    glass = draw_albedo("glass_facade", rng)
    height = floors * _FLOOR_M + rng.uniform(0.3, 1.2)
    pitch = rng.uniform(3.2, 4.2)
    sid = b.prism(footprint, 0.0, height, wall_a, BUILDING, top_albedo=roof)
    for k in range(1 if shop_front else 4):
        _windows(b, sid, footprint[k], footprint[(k + 1) % 4], floors, glass, pitch, shop=shop_front)


def wall(b: SolidBuilder, albedo, footprint: np.ndarray, height: float) -> None:
    """One wall piece over a quadrilateral ``footprint`` (4, 2), ``height`` m high."""
    b.prism(footprint, 0.0, height, albedo, WALL)


def guard_rail(b: SolidBuilder, steel, p: np.ndarray, n: np.ndarray, posts: np.ndarray, post_n: np.ndarray) -> None:
    """A W-beam along the polyline ``p`` (K, 2) (its road-side face; ``n`` (K, 2)
    the outward normals there), one straight piece between consecutive points, and
    a post behind the beam at each point of ``posts`` (P, 2) (normals ``post_n``)."""
    back = n * 0.08
    for k in range(len(p) - 1):
        fp = np.array([p[k], p[k + 1], p[k + 1] + back[k + 1], p[k] + back[k]])
        b.prism(fp, 0.45, 0.75, steel, GUARDRAIL)
    for at, nk in zip(posts, post_n):
        heading = math.atan2(-nk[0], nk[1])
        b.prism(rect(at + nk * 0.14, heading, 0.12, 0.1), 0.0, 0.7, steel * np.float32(0.8), GUARDRAIL)


def overpass(
    b: SolidBuilder, rng: np.random.Generator, centre: np.ndarray, heading: float, t0: float, t1: float
) -> None:
    """A deck across the road (``heading`` is the road's; the deck spans ``[t0, t1]``
    m along the road's normal from ``centre`` plus abutments beyond)."""
    conc = draw_albedo("concrete", rng)
    n = np.array([-math.sin(heading), math.cos(heading)])
    depth, bottom, thick = rng.uniform(8.0, 12.0), rng.uniform(5.0, 6.5), rng.uniform(1.0, 1.5)
    lo, hi = t0 - 3.0, t1 + 3.0
    mid = centre + n * (lo + hi) / 2
    b.prism(rect(mid, heading + np.pi / 2, hi - lo + 2.0, depth), bottom, bottom + thick, conc, OVERPASS, bottom=True)
    for t in (lo - 0.2, hi + 0.2):
        b.prism(rect(centre + n * t, heading + np.pi / 2, 1.4, depth), 0.0, bottom, conc * np.float32(0.9), OVERPASS)
