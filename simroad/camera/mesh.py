"""Things with height in the world: convex solids as lists of planar faces.

Scenery (trees, poles, signs, buildings, walls, guard rails, overpasses) and vehicles
reach the camera in one form, a :class:`Mesh`: planar convex faces in world metres
(x, y on the ground, z up), each with a linear albedo, a material code, an outward
normal and the id of the convex solid it bounds. The renderer paints faces with
depth ordering; the shadow noise casts the shadow of every solid (the convex hull of
its vertices projected along the sun onto the ground), so a shadow never lacks its
caster.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MAX_VERTICES", "Mesh"]

#: Vertices per face at most (faces with fewer repeat their last vertex).
MAX_VERTICES = 16


@dataclass(frozen=True)
class Mesh:
    """Planar convex faces in world coordinates (metres, z up).

    Attributes
    ----------
    vertices : ndarray float64 (F, MAX_VERTICES, 3)
        Face corners in order around the face; a face with ``k < MAX_VERTICES``
        corners repeats its last one.
    counts : ndarray int32 (F,)
        Number of corners of each face (>= 3).
    albedo : ndarray float32 (F, 3)
        Linear RGB reflectance of each face in [0, 1] (emitters such as lit tail
        lights may exceed it).
    material : ndarray uint8 (F,)
        Material code of each face (:data:`simroad.camera.world.MATERIAL_NAMES`).
    normal : ndarray float64 (F, 3)
        Outward unit normal of each face; faces whose normal points away from the
        camera are not drawn.
    solid : ndarray int64 (F,)
        Id of the convex solid each face bounds (unique within one mesh); the
        shadow of a solid is the hull of its vertices projected along the sun.
    """

    vertices: np.ndarray
    counts: np.ndarray
    albedo: np.ndarray
    material: np.ndarray
    normal: np.ndarray
    solid: np.ndarray

    def __len__(self) -> int:
        return len(self.counts)

    @classmethod
    def empty(cls) -> Mesh:
        return cls(
            np.zeros((0, MAX_VERTICES, 3)),
            np.zeros(0, dtype=np.int32),
            np.zeros((0, 3), dtype=np.float32),
            np.zeros(0, dtype=np.uint8),
            np.zeros((0, 3)),
            np.zeros(0, dtype=np.int64),
        )

    @classmethod
    def concat(cls, parts: list[Mesh]) -> Mesh:
        """One mesh of all ``parts``; solid ids are renumbered so they stay unique."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        solids, offset = [], 0
        for p in parts:
            solids.append(p.solid + offset)
            offset += int(p.solid.max()) + 1
        return cls(
            np.concatenate([p.vertices for p in parts]),
            np.concatenate([p.counts for p in parts]),
            np.concatenate([p.albedo for p in parts]),
            np.concatenate([p.material for p in parts]),
            np.concatenate([p.normal for p in parts]),
            np.concatenate(solids),
        )

    def select(self, keep: np.ndarray) -> Mesh:
        """The faces ``keep`` (a boolean mask or indices)."""
        return Mesh(
            self.vertices[keep],
            self.counts[keep],
            self.albedo[keep],
            self.material[keep],
            self.normal[keep],
            self.solid[keep],
        )

    def bbox(self) -> np.ndarray:
        """Ground bounding box of each face, (F, 4): xmin, ymin, xmax, ymax."""
        v = self.vertices
        return np.column_stack([v[:, :, 0].min(1), v[:, :, 1].min(1), v[:, :, 0].max(1), v[:, :, 1].max(1)])
