"""Roadside occluders placed lazily per world cell, and the shadows they cast.

The world is cut into square cells. The occluders of cell (i, j) are drawn from a
generator seeded by ``(episode seed, i, j)``, so a cell's contents never depend on
which cells were visited before it. Trees, poles and buildings stand beside the road
(outside every lane's shoulder polygon, at a distance typical of their kind);
overpasses cross it.

Shadows on the ground plane: a point at height z casts its shadow at
``p − z·cot(e)·ŝ`` (ŝ the horizontal unit vector towards the sun, e the sun's
elevation). A prism (a convex footprint between heights z0 and z1: trunks, poles,
buildings, overpass decks) shadows the convex hull of its footprint shifted for z0
and for z1; a sphere (a tree's canopy, radius r at height h) shadows an ellipse with
semi-axes r across and r/sin(e) along ŝ, centred at the shifted centre. The penumbra
is ``w = (z / sin e)·tan(sun diameter)`` wide for an edge at height z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Occluders", "RoadIndex", "Shadows", "place_cell", "prism_shadows", "sphere_shadows"]

N_VERT = 16
KINDS = ("tree", "pole", "building")
KIND_P = np.array([0.55, 0.30, 0.15])
# Distance from the shoulder edge (m) at which each kind stands: (min, max).
KIND_BAND = {"tree": (0.5, 8.0), "pole": (0.3, 2.5), "building": (4.0, 16.0)}
_MEAN_BAND = float(sum(p * (hi - lo) for p, (lo, hi) in zip(KIND_P, KIND_BAND.values())))
CORRIDOR_HALF_M = 6.0  # road + shoulders assumed without a world, along world x


@dataclass
class Shadows:
    """Shadow polygons on the ground, world metres.

    Attributes
    ----------
    polys : ndarray (P, 16, 2)
        Convex polygons, padded by repeating the last vertex.
    penumbra_m : ndarray (P,)
        Penumbra width of each polygon's far edge, m.
    bbox : ndarray (P, 4)
        xmin, ymin, xmax, ymax.
    """

    polys: np.ndarray
    penumbra_m: np.ndarray
    bbox: np.ndarray

    @classmethod
    def empty(cls) -> Shadows:
        return cls(np.zeros((0, N_VERT, 2)), np.zeros(0), np.zeros((0, 4)))

    @classmethod
    def concat(cls, parts: list[Shadows]) -> Shadows:
        parts = [p for p in parts if len(p.penumbra_m)]
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("polys", "penumbra_m", "bbox")))

    def select(self, keep: np.ndarray) -> Shadows:
        return Shadows(self.polys[keep], self.penumbra_m[keep], self.bbox[keep])


def _finish(polys: np.ndarray, penumbra: np.ndarray) -> Shadows:
    bbox = np.column_stack([polys[:, :, 0].min(1), polys[:, :, 1].min(1), polys[:, :, 0].max(1), polys[:, :, 1].max(1)])
    return Shadows(polys, penumbra, bbox)


def sphere_shadows(
    centre: np.ndarray, height: np.ndarray, radius: np.ndarray, sun: tuple[float, float], sun_diam_rad: float
) -> Shadows:
    """Elliptic shadows of spheres; ``sun = (azimuth, elevation)`` in rad."""
    az, el = sun
    s = np.array([math.cos(az), math.sin(az)])
    n = np.array([-s[1], s[0]])
    cot, sin_e = 1.0 / math.tan(el), math.sin(el)
    ctr = centre - (height * cot)[:, None] * s
    phi = np.linspace(0.0, 2 * np.pi, N_VERT, endpoint=False)
    a = (radius / sin_e)[:, None, None] * np.cos(phi)[None, :, None] * s
    b = radius[:, None, None] * np.sin(phi)[None, :, None] * n
    polys = ctr[:, None, :] + a + b
    return _finish(polys, height / sin_e * math.tan(sun_diam_rad))


def prism_shadows(
    footprints: list[np.ndarray], z0: np.ndarray, z1: np.ndarray, sun: tuple[float, float], sun_diam_rad: float
) -> Shadows:
    """Shadows of vertical prisms (convex footprint (K, 2), heights z0 < z1, m)."""
    if not footprints:
        return Shadows.empty()
    az, el = sun
    s = np.array([math.cos(az), math.sin(az)]) / math.tan(el)
    polys = np.empty((len(footprints), N_VERT, 2))
    for k, fp in enumerate(footprints):
        pts = np.vstack([fp - z0[k] * s, fp - z1[k] * s]).astype(np.float32)
        hull = cv2.convexHull(pts).reshape(-1, 2)[:N_VERT]
        polys[k, : len(hull)] = hull
        polys[k, len(hull) :] = hull[-1]
    return _finish(polys, z1 / math.sin(el) * math.tan(sun_diam_rad))


def _rect(centre: np.ndarray, heading: float, length: float, width: float) -> np.ndarray:
    c, s = math.cos(heading), math.sin(heading)
    f, r = np.array([c, s]) * length / 2, np.array([-s, c]) * width / 2
    return np.array([centre + f - r, centre + f + r, centre - f + r, centre - f - r])


class RoadIndex:
    """Lane outlines for placement: distance to the road and lane centrelines.

    Parameters
    ----------
    shapes : list of LaneShape or None
        ``WorldRaster.shapes`` (their ``surface`` polygons); ``None`` assumes a
        straight road along world x, ``CORRIDOR_HALF_M`` on each side of y = 0 (road
        and shoulders).
    shoulder_m : float
        Shoulder width beside each lane surface, m.
    """

    def __init__(self, shapes=None, shoulder_m: float = 1.0) -> None:
        self.straight = shapes is None
        self.shoulder_m = float(shoulder_m)
        self.contours: list[np.ndarray] = []
        self.centres: list[np.ndarray] = []
        boxes: list[tuple[float, float, float, float]] = []
        for sh in shapes or []:
            surf = np.asarray(sh.surface, dtype=float)
            self.contours.append(surf.astype(np.float32).reshape(-1, 1, 2))
            lo, hi = surf.min(axis=0) - self.shoulder_m, surf.max(axis=0) + self.shoulder_m
            boxes.append((lo[0], lo[1], hi[0], hi[1]))
            half = len(surf) // 2
            self.centres.append(0.5 * (surf[:half] + surf[::-1][:half]))
        self.bboxes = np.asarray(boxes, dtype=float).reshape(-1, 4)

    def distance(self, pts: np.ndarray, reach: float) -> np.ndarray:
        """Distance (m) from points (N, 2) to the road's shoulder edge; ``-1`` on the
        road or its shoulder, ``inf`` farther than ``reach`` from any lane."""
        if self.straight:
            d = np.abs(pts[:, 1]) - CORRIDOR_HALF_M
            return np.where(d < 0, -1.0, d)
        out = np.full(len(pts), np.inf)
        b = self.bboxes
        for k, (x, y) in enumerate(pts):
            near = np.flatnonzero(
                (b[:, 0] - reach <= x) & (b[:, 2] + reach >= x) & (b[:, 1] - reach <= y) & (b[:, 3] + reach >= y)
            )
            for c in near:
                d = -cv2.pointPolygonTest(self.contours[c], (float(x), float(y)), True) - self.shoulder_m
                out[k] = min(out[k], d)
        return np.where(out < 0, -1.0, out)

    def crossing_in(
        self, box: tuple[float, float, float, float], rng: np.random.Generator
    ) -> tuple[np.ndarray, float] | None:
        """A random lane-centre point in ``box`` and the lane's heading there."""
        if self.straight:
            if box[1] > 0 or box[3] < 0:
                return None
            return np.array([rng.uniform(box[0], box[2]), 0.0]), 0.0
        cands: list[tuple[np.ndarray, int]] = []
        for c in self.centres:
            inside = np.flatnonzero((c[:, 0] >= box[0]) & (c[:, 0] < box[2]) & (c[:, 1] >= box[1]) & (c[:, 1] < box[3]))
            cands += [(c, int(i)) for i in inside]
        if not cands:
            return None
        c, i = cands[int(rng.integers(len(cands)))]
        j = min(i + 1, len(c) - 1)
        i0 = j - 1 if j > 0 else 0
        d = c[j] - c[i0]
        return c[i].copy(), math.atan2(d[1], d[0])


@dataclass
class Occluders:
    """The occluders of one cell (world metres).

    Attributes
    ----------
    kinds : list of str
        Kind of each prism: "tree" (trunk), "pole", "building" or "overpass".
    footprints : list of ndarray (4, 2)
        Prism footprints.
    z0, z1 : ndarray
        Bottom and top height of each prism, m.
    canopy_centre : ndarray (T, 2)
        Trees' canopy centres; ``canopy_height`` (T,) and ``canopy_radius`` (T,), m.
    """

    kinds: list
    footprints: list
    z0: np.ndarray
    z1: np.ndarray
    canopy_centre: np.ndarray
    canopy_height: np.ndarray
    canopy_radius: np.ndarray

    def shadows(self, sun: tuple[float, float], sun_diam_rad: float) -> Shadows:
        """Their shadows for the sun ``(azimuth, elevation)`` in rad."""
        parts = [prism_shadows(self.footprints, self.z0, self.z1, sun, sun_diam_rad)]
        if len(self.canopy_radius):
            parts.append(sphere_shadows(self.canopy_centre, self.canopy_height, self.canopy_radius, sun, sun_diam_rad))
        return Shadows.concat(parts)


def _roadside(name: str, at: np.ndarray, u: np.ndarray, dist: float):
    """Footprint, height and (trees) canopy of an occluder of kind ``name`` drawn from
    the uniforms ``u`` at ``at``, or None if ``dist`` from the road does not suit it."""
    lo, hi = KIND_BAND[name]
    if name == "building":
        w, l, h, yaw = 6 + 10 * u[0], 6 + 10 * u[1], 4 + 10 * u[2], math.pi * u[3]
        half = 0.5 * math.hypot(w, l)
        return (_rect(at, yaw, l, w), h, None) if lo + half <= dist <= hi + half else None
    if not lo <= dist <= hi:
        return None
    if name == "tree":
        trunk, r, rad = 1.5 + 2.0 * u[0], 1.5 + 2.0 * u[1], 0.15 + 0.15 * u[2]
        return _rect(at, 0.0, 2 * rad, 2 * rad), trunk + 0.3 * r, (at, trunk + 0.8 * r, r)
    height, rad = 6.0 + 5.0 * u[0], 0.10 + 0.08 * u[1]  # pole
    return _rect(at, 0.0, 2 * rad, 2 * rad), height, None


def place_cell(
    rng: np.random.Generator,
    box: tuple[float, float, float, float],
    road: RoadIndex,
    *,
    per_100m: float,
    overpass_per_km: float,
) -> Occluders:
    """Place one cell's occluders.

    Parameters
    ----------
    rng : numpy.random.Generator
        The cell's own generator.
    box : (xmin, ymin, xmax, ymax)
        The cell, world metres.
    per_100m : float
        Roadside occluders per 100 m of road (both sides; approximate on curves).
    overpass_per_km : float
        Overpasses per km of road.
    """
    x0, y0, x1, y1 = box
    n = int(rng.poisson(per_100m / (100.0 * 2.0 * _MEAN_BAND) * (x1 - x0) * (y1 - y0)))
    pts = np.column_stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)])
    kind = rng.choice(len(KINDS), size=n, p=KIND_P)
    dims = rng.random((n, 4))
    dist = road.distance(pts, reach=20.0)
    kinds, fps, z0, z1, trees = [], [], [], [], []
    for k in range(n):
        placed = _roadside(KINDS[kind[k]], pts[k], dims[k], dist[k])
        if placed is not None:
            kinds.append(KINDS[kind[k]])
            fps.append(placed[0])
            z0.append(0.0)
            z1.append(placed[1])
            if placed[2] is not None:
                trees.append(placed[2])
    if overpass_per_km > 0 and rng.random() < min(1.0, overpass_per_km * (x1 - x0) / 1000.0):
        hit = road.crossing_in(box, rng)
        if hit is not None:
            depth, bottom = 8.0 + 6.0 * rng.random(), 5.0 + 1.5 * rng.random()
            kinds.append("overpass")
            fps.append(_rect(hit[0], hit[1], depth, 36.0))
            z0.append(bottom)
            z1.append(bottom + 1.2)
    return Occluders(
        kinds,
        fps,
        np.array(z0, dtype=float),
        np.array(z1, dtype=float),
        np.array([t[0] for t in trees]).reshape(-1, 2),
        np.array([t[1] for t in trees], dtype=float),
        np.array([t[2] for t in trees], dtype=float),
    )
