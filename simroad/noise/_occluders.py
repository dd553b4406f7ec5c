"""Shadow polygons on the ground, cast by the world's solids and by vehicle boxes.

A point at height z casts its shadow at ``p − z·cot(e)·ŝ`` on the ground plane (ŝ
the horizontal unit vector towards the sun, e the sun's elevation). Every solid of
the world is convex (:class:`simroad.camera.mesh.Mesh`), so its shadow is the convex
hull of its vertices so projected (:func:`mesh_shadows`); a vehicle box is the prism
over its footprint (:func:`prism_shadows`). The penumbra of a shadow's far edge is
``w = (z / sin e)·tan(sun diameter)`` wide for the caster's top at height z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from simroad.camera.mesh import Mesh

__all__ = ["N_VERT", "Shadows", "mesh_shadows", "prism_shadows", "project_to_ground"]

#: Corners per shadow polygon at most (shorter polygons repeat their last corner).
N_VERT = 32


@dataclass
class Shadows:
    """Shadow polygons on the ground, world metres.

    Attributes
    ----------
    polys : ndarray (P, N_VERT, 2)
        Convex polygons, padded by repeating the last vertex.
    penumbra_m : ndarray (P,)
        Penumbra width of each polygon's far edge, m.
    bbox : ndarray (P, 4)
        xmin, ymin, xmax, ymax.
    caster : ndarray int64 (P,)
        Solid id (in the mesh the shadows were cast from) of each polygon's caster;
        -1 for vehicle and ego boxes.
    """

    polys: np.ndarray
    penumbra_m: np.ndarray
    bbox: np.ndarray
    caster: np.ndarray

    def __len__(self) -> int:
        return len(self.penumbra_m)

    @classmethod
    def empty(cls) -> Shadows:
        return cls(np.zeros((0, N_VERT, 2)), np.zeros(0), np.zeros((0, 4)), np.zeros(0, dtype=np.int64))

    @classmethod
    def concat(cls, parts: list[Shadows]) -> Shadows:
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("polys", "penumbra_m", "bbox", "caster")))

    def select(self, keep: np.ndarray) -> Shadows:
        return Shadows(self.polys[keep], self.penumbra_m[keep], self.bbox[keep], self.caster[keep])


def _finish(polys: np.ndarray, penumbra: np.ndarray, caster: np.ndarray) -> Shadows:
    bbox = np.column_stack([polys[:, :, 0].min(1), polys[:, :, 1].min(1), polys[:, :, 0].max(1), polys[:, :, 1].max(1)])
    return Shadows(polys, penumbra, bbox, caster)


def project_to_ground(xyz: np.ndarray, sun: tuple[float, float]) -> np.ndarray:
    """Ground points (..., 2) where the sun ``(azimuth, elevation)`` (rad) casts the
    points ``xyz`` (..., 3): ``p − z·cot(e)·ŝ``."""
    az, el = sun
    s = np.array([math.cos(az), math.sin(az)]) / math.tan(el)
    return xyz[..., :2] - xyz[..., 2:3] * s


def _pad(hull: np.ndarray) -> np.ndarray:
    """A hull (K, 2) as N_VERT corners (simplified if K > N_VERT)."""
    if len(hull) > N_VERT:
        eps = 0.01
        while len(hull) > N_VERT:
            hull = cv2.approxPolyDP(hull.astype(np.float32).reshape(-1, 1, 2), eps, True).reshape(-1, 2)
            eps *= 2.0
    out = np.empty((N_VERT, 2))
    out[: len(hull)] = hull
    out[len(hull) :] = hull[-1]
    return out


def mesh_shadows(mesh: Mesh, sun: tuple[float, float], sun_diam_rad: float) -> Shadows:
    """The shadow of every solid of ``mesh``: the convex hull of its projected
    vertices, with the penumbra of its highest vertex."""
    if not len(mesh):
        return Shadows.empty()
    order = np.argsort(mesh.solid, kind="stable")
    ids, start = np.unique(mesh.solid[order], return_index=True)
    stop = np.append(start[1:], len(order))
    ground = project_to_ground(mesh.vertices[order], sun).astype(np.float32)  # (F, 16, 2)
    top = mesh.vertices[order][:, :, 2].max(axis=1)
    polys = np.empty((len(ids), N_VERT, 2))
    z1 = np.empty(len(ids))
    for k, (a, b) in enumerate(zip(start.tolist(), stop.tolist())):
        polys[k] = _pad(cv2.convexHull(ground[a:b].reshape(-1, 2)).reshape(-1, 2))
        z1[k] = top[a:b].max()
    return _finish(polys, z1 / math.sin(sun[1]) * math.tan(sun_diam_rad), ids.astype(np.int64))


def prism_shadows(
    footprints: list[np.ndarray], z0: np.ndarray, z1: np.ndarray, sun: tuple[float, float], sun_diam_rad: float
) -> Shadows:
    """Shadows of vertical prisms (convex footprint (K, 2), heights z0 < z1, m)."""
    if not footprints:
        return Shadows.empty()
    polys = np.empty((len(footprints), N_VERT, 2))
    for k, fp in enumerate(footprints):
        lo = np.column_stack([fp, np.full(len(fp), z0[k])])
        hi = np.column_stack([fp, np.full(len(fp), z1[k])])
        pts = project_to_ground(np.vstack([lo, hi]), sun).astype(np.float32)
        polys[k] = _pad(cv2.convexHull(pts).reshape(-1, 2))
    caster = np.full(len(footprints), -1, dtype=np.int64)
    return _finish(polys, np.asarray(z1) / math.sin(sun[1]) * math.tan(sun_diam_rad), caster)
