"""Which candidate scenery objects give way: no two objects' solids may intersect.

The painter orders convex solids exactly only when they do not interpenetrate, so
every placed object must be clear of every other one (only tree crowns may overlap
other trees' crowns, as real canopies do). :mod:`simroad.camera.scenery` draws the
*candidates* of each world cell from the seed alone; an object stays unless it
intersects a candidate of higher priority (lower ``(rank, cell, index)``) from its
own or a neighbouring cell. That depends on the candidates only, so every cell stays
a pure function of the seed and its index.

Two convex solids are taken as separate when some face plane of one has every
vertex of the other on its outer side (``TOUCH_M`` of tolerance): exact for the
boxes and prisms of the scenery, and conservative otherwise (it may call a pair
intersecting that an edge-edge axis separates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simroad.camera._scenery_solids import SolidBuilder
from simroad.camera.mesh import Mesh

__all__ = ["TOUCH_M", "Candidates", "kept_objects", "solids_separated"]

#: Solids overlapping by less than this (m) only touch (abutting facades, a sign
#: plate on its post).
TOUCH_M = 0.01


@dataclass(frozen=True)
class Candidates:
    """The candidate objects of one cell: their mesh and per-solid facts.

    ``prio`` (S,) int64 orders solids' objects globally (smaller wins); ``key``
    (S,) int64 names the object (the same for pieces of one run: a rail's
    segments); ``crown`` (S,) bool; ``lo``, ``hi`` (S, 3) the solids' boxes;
    ``index`` maps a solid id of ``mesh`` to its row.
    """

    mesh: Mesh
    obj: np.ndarray
    prio: np.ndarray
    key: np.ndarray
    crown: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def build(cls, b: SolidBuilder, cell_code: int) -> Candidates:
        """Candidates from a finished builder; ``cell_code`` < 2**32 numbers the cell."""
        mesh = b.mesh()
        n = len(b.solid_object)
        obj = np.asarray(b.solid_object, dtype=np.int64).reshape(n)
        rank = np.asarray(b.object_rank, dtype=np.int64)
        group = np.asarray(b.object_group, dtype=np.int64)
        prio = (rank[obj] << 56) | (np.int64(cell_code) << 24) | obj if n else np.zeros(0, np.int64)
        ident = (np.int64(cell_code) << 24) | obj
        key = np.where(group[obj] >= 0, -1 - group[obj], ident) if n else np.zeros(0, np.int64)
        lo, hi = np.full((n, 3), np.inf), np.full((n, 3), -np.inf)
        if len(mesh):
            w = np.arange(mesh.vertices.shape[1])[None, :] < mesh.counts[:, None]
            vmin = np.where(w[..., None], mesh.vertices, np.inf).min(axis=1)
            vmax = np.where(w[..., None], mesh.vertices, -np.inf).max(axis=1)
            np.minimum.at(lo, mesh.solid, vmin)
            np.maximum.at(hi, mesh.solid, vmax)
        return cls(mesh, obj, prio, key, np.asarray(b.solid_crown, dtype=bool).reshape(n), lo, hi)

    def solid(self, sid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Face normals (F, 3), a point of each face (F, 3) and the vertices (V, 3)."""
        m = self.mesh
        faces = np.flatnonzero(m.solid == sid)
        verts = np.concatenate([m.vertices[f, : m.counts[f]] for f in faces.tolist()])
        return m.normal[faces], m.vertices[faces, 0], verts


def solids_separated(a, b, tol: float = TOUCH_M) -> bool:
    """True if a face plane of one solid has every vertex of the other outside
    (within ``tol``); ``a``, ``b`` as :meth:`Candidates.solid`."""
    for (n, p, _), (_, _, v) in ((a, b), (b, a)):
        d = np.einsum("fk,vfk->fv", n, v[:, None, :] - p[None, :, :])
        if (d.min(axis=1) >= -tol).any():
            return True
    return False


def kept_objects(own: Candidates, hood: list[Candidates]) -> np.ndarray:
    """Bool per solid of ``own``: its object intersects no higher-priority candidate
    of ``hood`` (which includes ``own``), crown-crown pairs and pieces of one run
    excepted."""
    keep = np.ones(len(own.obj), dtype=bool)
    if not len(own.obj):
        return keep
    lo = np.concatenate([h.lo for h in hood])
    hi = np.concatenate([h.hi for h in hood])
    prio = np.concatenate([h.prio for h in hood])
    key = np.concatenate([h.key for h in hood])
    crown = np.concatenate([h.crown for h in hood])
    where = np.concatenate([np.full(len(h.obj), q) for q, h in enumerate(hood)])
    row = np.concatenate([np.arange(len(h.obj)) for h in hood])
    near = ((own.lo[:, None] < hi[None] - TOUCH_M) & (own.hi[:, None] > lo[None] + TOUCH_M)).all(axis=2)
    near &= prio[None] < own.prio[:, None]
    near &= key[None] != own.key[:, None]
    near &= ~(crown[None] & own.crown[:, None])
    blocked_obj: set[int] = set()
    for s, t in zip(*np.nonzero(near)):
        o = int(own.obj[s])
        if o in blocked_obj:
            continue
        other = hood[int(where[t])]
        if not solids_separated(own.solid(int(s)), other.solid(int(row[t]))):
            blocked_obj.add(o)
    if blocked_obj:
        keep = ~np.isin(own.obj, list(blocked_obj))
    return keep
