"""Convex solids as faces: boxes, prisms, canopy polyhedra and facade decals.

:class:`SolidBuilder` collects the faces of one world cell's scenery and finishes
them into one :class:`~simroad.camera.mesh.Mesh`: outward normals from the face
corners (Newell's method, oriented away from the solid's centroid), one solid id
per convex solid, and decals (windows, sign faces) as later coplanar faces of the
solid they sit on.
"""

from __future__ import annotations

import math

import numpy as np

from simroad.camera.mesh import MAX_VERTICES, Mesh

__all__ = ["CANOPY_TEMPLATES", "SolidBuilder", "outline", "rect"]


def rect(centre: np.ndarray, heading: float, length: float, width: float) -> np.ndarray:
    """Corners (4, 2) of a rectangle, ``length`` along ``heading`` (rad), m."""
    c, s = math.cos(heading), math.sin(heading)
    f, r = np.array([c, s]) * length / 2, np.array([-s, c]) * width / 2
    return np.array([centre + f - r, centre + f + r, centre - f + r, centre - f - r])


def outline(poly: np.ndarray, step: float = 2.0) -> np.ndarray:
    """Points every ``step`` m or less around a polygon (K, 2), and its centre."""
    out = [poly.mean(axis=0)[None]]
    for a, c in zip(poly, np.roll(poly, -1, axis=0)):
        n = max(1, math.ceil(float(np.hypot(*(c - a))) / step))
        out.append(a + np.linspace(0.0, 1.0, n, endpoint=False)[:, None] * (c - a))
    return np.vstack(out)


#: The triangles of the six ``round`` canopies' convex hulls (vertex indices, as Qhull
#: gives them for the points below; tests/camera/test_scenery_hulls.py checks that they
#: are the hulls). Written out: the same faces in the same order whatever the Qhull
#: build, and no SciPy import for every process that renders.
_ROUND_HULLS = (
    ((6, 3, 1), (5, 6, 3), (0, 1, 2), (0, 3, 1), (0, 5, 2), (0, 5, 3), (4, 1, 2), (4, 6, 1), (4, 5, 2), (4, 5, 6)),
    ((6, 3, 1), (4, 2, 1), (4, 6, 1), (0, 2, 1), (0, 3, 1), (5, 6, 3), (5, 0, 2), (5, 0, 3), (5, 4, 2), (5, 4, 6)),
    ((0, 3, 5), (1, 0, 3), (6, 4, 5), (6, 3, 5), (6, 1, 4), (6, 1, 3), (2, 4, 5), (2, 0, 5), (2, 1, 4), (2, 1, 0)),
    ((1, 2, 4), (5, 2, 4), (0, 1, 3), (0, 1, 2), (0, 5, 3), (0, 5, 2), (6, 5, 3), (6, 5, 4), (6, 1, 3), (6, 1, 4)),
    ((0, 5, 3), (6, 5, 4), (6, 5, 3), (1, 0, 3), (1, 6, 4), (1, 6, 3), (2, 5, 4), (2, 0, 5), (2, 1, 4), (2, 1, 0)),
    ((1, 2, 4), (5, 2, 4), (0, 1, 3), (0, 1, 2), (0, 5, 3), (0, 5, 2), (6, 5, 3), (6, 5, 4), (6, 1, 3), (6, 1, 4)),
)


def _canopy_templates() -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """Unit canopy polyhedra (vertices (V, 3), triangle/face index lists).

    ``round``: hulls of 7 points spread on a unit sphere (10 faces), the
    crowns of deciduous trees; ``cone``: a conifer, an apex over a ring of 6 points
    (7 faces), base at z = 0 and apex at z = 1. Fixed at import (their own seed),
    so every world shares them and per-tree draws only scale and turn them.
    """
    rng = np.random.default_rng(20261201)
    out: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"round": [], "cone": []}
    n = 7  # points per round crown
    for hull in _ROUND_HULLS:
        golden = np.pi * (3.0 - math.sqrt(5.0))
        k = np.arange(n) + 0.5
        z = 1.0 - 2.0 * k / n
        r = np.sqrt(1.0 - z * z)
        phi = golden * np.arange(n) + rng.uniform(0, 2 * np.pi)
        v = np.column_stack([r * np.cos(phi), r * np.sin(phi), z]) * rng.uniform(0.85, 1.0, (n, 1))
        out["round"].append((v, np.array(hull, dtype=np.int32)))
    for _ in range(4):
        phi = np.sort(np.linspace(0, 2 * np.pi, 6, endpoint=False) + rng.uniform(-0.2, 0.2, 6))
        ring = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(6)]) * rng.uniform(0.85, 1.0, (6, 1))
        v = np.vstack([ring, [[0.0, 0.0, 1.0]]])
        faces = [np.array([k, (k + 1) % 6, 6]) for k in range(6)] + [np.arange(6)[::-1]]
        out["cone"].append((v, np.array(faces, dtype=object)))
    return out


#: Canopy shapes (see :func:`_canopy_templates`).
CANOPY_TEMPLATES = _canopy_templates()


class SolidBuilder:
    """Accumulates convex solids and decals; :meth:`mesh` finishes them.

    Solids belong to *objects* (a tree: trunk and crown; a building and its
    windows): :meth:`begin` opens one with its placement ``rank`` (lower ranks are
    placed first, see :mod:`simroad.camera.scenery`) and an optional ``group`` (the
    pieces of one guard rail or wall run share one). ``solid_object``,
    ``solid_crown``, ``object_rank`` and ``object_group`` describe them.
    """

    def __init__(self) -> None:
        self._verts: list[np.ndarray] = []
        self._albedo: list[np.ndarray] = []
        self._material: list[int] = []
        self._solid: list[int] = []
        self._decal: list[bool] = []
        self._next = 0
        self.solid_object: list[int] = []
        self.solid_crown: list[bool] = []
        self.object_rank: list[int] = []
        self.object_group: list[int] = []

    def begin(self, rank: int, group: int = -1) -> int:
        """Open a new object (every later solid belongs to it); returns its index."""
        self.object_rank.append(int(rank))
        self.object_group.append(int(group))
        return len(self.object_rank) - 1

    def __len__(self) -> int:
        return len(self._verts)

    def keep_within(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Drop every object with a corner outside the ground box ``lo``-``hi`` (2,)
        (its solids stay numbered, without faces)."""
        bad = {
            self.solid_object[s]
            for v, s in zip(self._verts, self._solid)
            if (v[:, :2] < lo).any() or (v[:, :2] > hi).any()
        }
        if bad:
            keep = [self.solid_object[s] not in bad for s in self._solid]
            for name in ("_verts", "_albedo", "_material", "_solid", "_decal"):
                setattr(self, name, [x for x, k in zip(getattr(self, name), keep) if k])

    def _face(self, verts: np.ndarray, albedo, material: int, solid: int, decal: bool = False) -> None:
        self._verts.append(np.asarray(verts, dtype=float))
        self._albedo.append(np.asarray(albedo, dtype=np.float32))
        self._material.append(int(material))
        self._solid.append(solid)
        self._decal.append(decal)

    def new_solid(self, *, crown: bool = False) -> int:
        if not self.object_rank:
            self.begin(0)
        self.solid_object.append(len(self.object_rank) - 1)
        self.solid_crown.append(crown)
        self._next += 1
        return self._next - 1

    def prism(
        self,
        footprint: np.ndarray,
        z0: float,
        z1: float,
        albedo,
        material: int,
        *,
        top_albedo=None,
        bottom: bool = False,
    ) -> int:
        """A vertical prism over a convex ``footprint`` (K, 2) from ``z0`` to ``z1``
        (m); returns its solid id. Side ``k`` joins corners ``k`` and ``k + 1``."""
        sid = self.new_solid()
        fp = np.asarray(footprint, dtype=float)
        n = len(fp)
        lo = np.column_stack([fp, np.full(n, z0)])
        hi = np.column_stack([fp, np.full(n, z1)])
        self._face(hi, albedo if top_albedo is None else top_albedo, material, sid)
        if bottom:
            self._face(lo[::-1], albedo, material, sid)
        for k in range(n):
            a, b = k, (k + 1) % n
            self._face(np.array([lo[a], lo[b], hi[b], hi[a]]), albedo, material, sid)
        return sid

    def polyhedron(self, verts: np.ndarray, faces, albedo, material: int, *, crown: bool = False) -> int:
        """A convex polyhedron from vertices (V, 3) and its faces' vertex indices
        (``crown``: a tree crown, which may overlap other trees' crowns)."""
        sid = self.new_solid(crown=crown)
        for f in faces:
            self._face(verts[np.asarray(f, dtype=int)], albedo, material, sid)
        return sid

    def decal(self, solid: int, verts: np.ndarray, albedo, material: int) -> None:
        """A flat face painted over a coplanar face of ``solid`` (a window, a sign)."""
        self._face(verts, albedo, material, solid, decal=True)

    def mesh(self) -> Mesh:
        """The collected faces as one :class:`Mesh` (normals oriented outwards)."""
        if not self._verts:
            return Mesh.empty()
        F = len(self._verts)
        counts = np.array([len(v) for v in self._verts], dtype=np.int32)
        verts = np.empty((F, MAX_VERTICES, 3))
        for k, v in enumerate(self._verts):
            verts[k, : len(v)] = v
            verts[k, len(v) :] = v[-1]
        solid = np.asarray(self._solid, dtype=np.int64)
        # Newell normal of each face (padding repeats the last corner: no area).
        nxt = np.roll(verts, -1, axis=1)  # the last (padding) corner wraps to the first
        normal = np.stack(
            [
                ((verts[..., 1] - nxt[..., 1]) * (verts[..., 2] + nxt[..., 2])).sum(1),
                ((verts[..., 2] - nxt[..., 2]) * (verts[..., 0] + nxt[..., 0])).sum(1),
                ((verts[..., 0] - nxt[..., 0]) * (verts[..., 1] + nxt[..., 1])).sum(1),
            ],
            axis=1,
        )
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        body = ~np.asarray(self._decal)
        w = np.arange(MAX_VERTICES)[None, :] < counts[:, None]
        centre_face = (verts * w[..., None]).sum(1) / counts[:, None]
        n_solid = int(solid.max()) + 1
        sums = np.zeros((n_solid, 3))
        np.add.at(sums, solid[body], centre_face[body])
        cnt = np.bincount(solid[body], minlength=n_solid)[:, None]
        centroid = sums / np.maximum(cnt, 1)
        flip = ((centre_face - centroid[solid]) * normal).sum(1) < 0
        normal[flip] *= -1
        for f in np.flatnonzero(flip).tolist():  # keep corners counter-clockwise seen from outside
            nk = int(counts[f])
            verts[f, :nk] = verts[f, :nk][::-1]
            verts[f, nk:] = verts[f, nk - 1]
        return Mesh(
            verts,
            counts,
            np.asarray(self._albedo, dtype=np.float32),
            np.asarray(self._material, dtype=np.uint8),
            normal,
            solid,
        )
