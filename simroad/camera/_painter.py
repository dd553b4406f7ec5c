"""Paint meshes into a camera frame with a z-buffer: exact occlusion, exact depth.

What does not depend on the camera (plane offsets, centroids, decal flags, bounding
spheres of the solids, flat colours) is computed once per
:class:`~simroad.camera.mesh.Mesh` object and cached; the scenery hands the same mesh
object over while the view stays within the same cells. Per frame, one compiled
kernel (:func:`simroad.camera._raster.rasterise`) culls solids by bounding sphere
(view frustum, range), back faces, faces beyond the range and faces below the level
of detail (a face whose screen box is below one pixel both ways; a decal, a face
coplanar with an earlier face of its solid: 1.5 px), clips faces to the near plane
and fills them scanline by scanline with a per-pixel depth test against what the
pixel sees (the flat ground's depth, ``inf`` for the sky). Occlusion is thus exact
for any solids, even intersecting ones; a later face of a solid wins a tie with an
earlier one, so decals (windows, lights) land on their base face. Colour, material
and face id then come by lookup through the face buffer. Depth is exact per pixel:
the horizontal distance from the camera to where the pixel's ray meets the face's
plane.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

import numpy as np
from numba import njit

from simroad.camera import _raster
from simroad.camera.geometry import PinholeCamera
from simroad.camera.lighting import radiance
from simroad.camera.mesh import Mesh
from simroad.core.radiometry import linear_to_srgb

__all__ = ["DECAL_LOD_PX", "LOD_PX", "NEAR_M", "MeshPainter", "clip_near", "face_colours"]

#: Near clipping plane, metres in front of the camera.
NEAR_M = 0.3
#: A face whose screen box is below this many pixels both ways is not drawn ...
LOD_PX = 1.0
#: ... and a decal (a face painted over a coplanar face of its solid) below this.
DECAL_LOD_PX = 1.5
_CACHE = 6  # prepared meshes kept (scenery windows, shadow queries, vehicles)
_NO_ROAD = np.zeros((1, 1), dtype=bool)  # shade() without a road mask to clear


def clip_near(poly: np.ndarray, near: float = NEAR_M) -> np.ndarray:
    """Sutherland-Hodgman clip of a camera-frame polygon (N, 3) to ``z >= near``."""
    out = []
    n = len(poly)
    for k in range(n):
        p, q = poly[k], poly[(k + 1) % n]
        pin, qin = p[2] >= near, q[2] >= near
        if pin:
            out.append(p)
        if pin != qin:
            t = (near - p[2]) / (q[2] - p[2])
            out.append(p + t * (q - p))
    return np.array(out) if out else np.zeros((0, 3))


def face_colours(mesh: Mesh) -> np.ndarray:
    """Flat sRGB colour (uint8 (F, 3)) of every face under the clear-weather light."""

    if not len(mesh):
        return np.zeros((0, 3), dtype=np.uint8)
    lin = radiance(mesh.albedo, mesh.normal[:, 2].astype(np.float32))
    # One row of pixels, at least two wide (OpenCV reads a 1x1x3 image as a scalar).
    row = np.ascontiguousarray(np.repeat(lin[None], 2, axis=1) if len(lin) == 1 else lin[None])
    return linear_to_srgb(row)[0][: len(lin)]


_COLOURS: OrderedDict[tuple[str, str, int, bytes], np.ndarray] = OrderedDict()


def _face_colours_f32(mesh: Mesh) -> np.ndarray:
    """:func:`face_colours` as float32, remembered by the faces' albedos and normals'
    z (the vehicles' mesh is new every frame, its colours seldom are)."""
    a, nz = mesh.albedo, np.ascontiguousarray(mesh.normal[:, 2])
    key = (a.dtype.str, nz.dtype.str, len(mesh), a.tobytes() + nz.tobytes())
    hit = _COLOURS.get(key)
    if hit is None:
        hit = _COLOURS[key] = face_colours(mesh).astype(np.float32)
        hit.flags.writeable = False
        if len(_COLOURS) > 4 * _CACHE:
            _COLOURS.popitem(last=False)
    else:
        _COLOURS.move_to_end(key)
    return hit


class _Prepared:
    """Camera-independent arrays of one mesh, in the kernels' types."""

    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh
        self.verts = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self.counts = np.ascontiguousarray(mesh.counts, dtype=np.int64)
        self.normal = np.ascontiguousarray(mesh.normal, dtype=np.float64)
        self.solid = np.ascontiguousarray(mesh.solid, dtype=np.int64)
        self.offset, self.centroid, self.decal, self.sphere = _raster.mesh_data(
            self.verts, self.counts, self.normal, self.solid
        )
        self.colour = _face_colours_f32(mesh)
        self.n_solids = len(self.sphere)


class MeshPainter:
    """Paints meshes through one camera (per-pixel ray tables are computed once).

    Parameters
    ----------
    camera : PinholeCamera
        The camera; its current pose is used at every :meth:`paint`.
    haze : ndarray float (3,), optional
        sRGB colour of the horizon haze: faces fade into it over the last 40 % of the
        camera's range, as the ground does. No fading when omitted.
    """

    def __init__(self, camera: PinholeCamera, *, haze: np.ndarray | None = None) -> None:
        self.camera = camera
        self.haze = None if haze is None else np.asarray(haze, dtype=np.float32).reshape(3)
        self._haze_or_none = np.full(3, np.nan, np.float32) if self.haze is None else self.haze
        c = camera.config
        K = camera.K
        u = (np.arange(c.width, dtype=np.float64) - K[0, 2]) / K[0, 0]
        v = (np.arange(c.height, dtype=np.float64) - K[1, 2]) / K[1, 1]
        self._xn, self._yn = u.astype(np.float32), v
        self._ray = np.ascontiguousarray(camera._R_ego, dtype=np.float64)  # (xn, yn, 1) @ ray: ego frame
        # Inward normals of the frustum's side planes (camera frame, through the centre).
        xl, xr = (-0.5 - K[0, 2]) / K[0, 0], (c.width - 0.5 - K[0, 2]) / K[0, 0]
        yt, yb = (-0.5 - K[1, 2]) / K[1, 1], (c.height - 0.5 - K[1, 2]) / K[1, 1]
        sides = np.array([[1.0, 0.0, -xl], [-1.0, 0.0, xr], [0.0, 1.0, -yt], [0.0, -1.0, yb]])
        self._sides = np.ascontiguousarray(sides / np.linalg.norm(sides, axis=1)[:, None])
        self._cache: OrderedDict[int, _Prepared] = OrderedDict()
        self._pose_key: tuple[float, ...] | None = None
        self._Mo = (np.eye(3), np.zeros(3))

    # ------------------------------------------------------------ transforms
    def _affine(self) -> tuple[np.ndarray, np.ndarray]:
        """``(M, o)`` with camera = world @ M + o (rows: points, world z up)."""
        cam = self.camera
        key = tuple(cam.pose)
        if self._pose_key == key:
            return self._Mo
        A = np.zeros((3, 3))
        A[:2, :2] = cam._R_we2.T
        A[2, 2] = -1.0
        p = np.zeros(3)
        p[:2] = -cam._pos @ cam._R_we2.T
        o = (p - cam._cam_ego) @ cam._R_ego.T
        self._Mo = (np.ascontiguousarray(A @ cam._R_ego.T), np.ascontiguousarray(o))
        self._pose_key = key
        return self._Mo

    def _prepared(self, mesh: Mesh) -> _Prepared:
        key = id(mesh)
        hit = self._cache.get(key)
        if hit is not None and hit.mesh is mesh:
            self._cache.move_to_end(key)
            return hit
        prep = _Prepared(mesh)
        self._cache[key] = prep
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return prep

    # ----------------------------------------------------------------- paint
    def paint(
        self,
        mesh: Mesh,
        rgb: np.ndarray,
        material: np.ndarray,
        depth: np.ndarray,
        *,
        colours: np.ndarray | None = None,
    ) -> np.ndarray:
        """Paint ``mesh`` over the frame in place and return the face-id map.

        Parameters
        ----------
        mesh : Mesh
            Faces in world metres.
        rgb : ndarray uint8 (H, W, 3)
        material : ndarray uint8 (H, W)
        depth : ndarray float32 (H, W)
            Horizontal distance in m from the camera to what each pixel sees (``inf``
            for the sky); a face is drawn where it is nearer, and overwrites it.
        colours : ndarray uint8 (F, 3), optional
            sRGB colour of each face; :func:`face_colours` (faded into the haze when
            the painter has one) when omitted.

        Returns
        -------
        ndarray int32 (H, W)
            Index into ``mesh`` of the face each pixel sees; -1 where none.
        """
        return self._paint([mesh] if len(mesh) else [], rgb, material, depth, colours, remap=False)[0]

    def paint_parts(
        self,
        parts: Sequence[Mesh],
        rgb: np.ndarray,
        material: np.ndarray,
        depth: np.ndarray,
        *,
        road: np.ndarray | None = None,
    ) -> tuple[np.ndarray, Mesh]:
        """Paint several meshes at once (e.g. the scenery and the vehicles, each
        prepared and cached on its own) and return what was drawn; the road mask
        ``road`` (bool (H, W), optional) is cleared where a face is seen.

        Returns
        -------
        face_id : ndarray int32 (H, W)
            Index into ``faces`` of the face each pixel sees; -1 where none.
        faces : Mesh
            The faces drawn (that passed culling and the level of detail, seen or
            hidden), part after part in mesh order (solid ids renumbered per part as
            :meth:`Mesh.concat` does).
        """
        parts = [p for p in parts if len(p)]
        fid, used = self._paint(parts, rgb, material, depth, None, remap=True, road=road)
        return fid, _drawn_faces(parts, used)

    # ------------------------------------------------------------------ core
    def _paint(self, parts, rgb, material, depth, colours, *, remap: bool, road: np.ndarray | None = None):
        """Rasterise ``parts`` into the frame (clearing ``road`` where a face is seen);
        return the face map and the drawn flags of every part (face indices are global
        over the parts unless ``remap``, which numbers the drawn faces only)."""
        cam = self.camera
        c = cam.config
        H, W = c.height, c.width
        fid = np.full((H, W), -1, dtype=np.int32)  # the face buffer, then the face map
        if not parts:
            return fid, []
        M, o = self._affine()
        cx, cy = cam.position_world
        camv = np.array(
            [cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2], NEAR_M, c.max_range_m, cx, cy, c.mount_height_m]
        )
        preps = [self._prepared(m) for m in parts]
        used, r0, r1, fbase = [], H, 0, 0
        for p in preps:
            u, a, b = _raster.rasterise(
                p.verts, p.counts, p.normal, p.offset, p.solid, p.decal, p.sphere, M, o, camv,
                self._sides, self._xn, self._yn, self._ray, depth, fid, fbase, LOD_PX, DECAL_LOD_PX,
            )  # fmt: skip
            used.append(u)
            r0, r1 = min(r0, a), max(r1, b)
            fbase += len(p.verts)
        if r1 <= r0:
            return fid, used
        G = fbase
        colour = np.zeros((G, 3), dtype=np.uint8)
        mat = np.zeros(G, dtype=np.uint8)
        table = np.full(G, -1, dtype=np.int32)
        haze = self._haze_or_none
        k, base = 0, 0
        for p, u in zip(preps, used):
            col = p.colour if colours is None else np.asarray(colours, dtype=np.float32)
            k = _raster.face_table(
                u, col, p.centroid, p.mesh.material, haze, cx, cy, c.max_range_m, base, k, remap, colour, mat, table
            )
            base += len(p.verts)
        _raster.shade(fid, r0, r1, colour, mat, table, rgb, material, _NO_ROAD if road is None else road)
        return fid, used


def _drawn_faces(parts: list[Mesh], used: list[np.ndarray]) -> Mesh:
    """The faces ``used`` (bool (F,) per part) of ``parts``, part after part, solid ids
    offset as :meth:`Mesh.concat` would offset the whole parts: one compiled gather
    into arrays of the types :meth:`Mesh.select` and ``np.concatenate`` would give."""
    counts = [int(np.count_nonzero(u)) for u in used]
    n = sum(counts)
    if not n:
        return Mesh.empty()
    drawn = [p for p, k in zip(parts, counts) if k]
    out = [
        np.empty((n, *getattr(drawn[0], f).shape[1:]), np.result_type(*(getattr(p, f) for p in drawn)))
        for f in Mesh.__dataclass_fields__
    ]
    k, off = 0, 0
    for p, u, c in zip(parts, used, counts):
        if c:
            # the ids' type and wrap-around of ``p.solid + off``
            k = _gather(
                u, p.vertices, p.counts, p.albedo, p.material, p.normal, p.solid, p.solid.dtype.type(off), k, *out
            )
        off += int(p.solid.max()) + 1
    return Mesh(*out)


@njit(cache=True, nogil=True)
def _gather(used, vertices, counts, albedo, material, normal, solid, off, k, o_v, o_c, o_a, o_m, o_n, o_s):  # pragma: no cover  # fmt: skip
    """Copy the faces ``used`` into the ``o_*`` arrays from row ``k`` on (solid ids
    plus ``off``); returns the next row."""
    for f in range(used.shape[0]):
        if used[f]:
            for i in range(vertices.shape[1]):
                for a in range(3):
                    o_v[k, i, a] = vertices[f, i, a]
            for a in range(3):
                o_a[k, a] = albedo[f, a]
                o_n[k, a] = normal[f, a]
            o_c[k] = counts[f]
            o_m[k] = material[f]
            o_s[k] = solid[f] + off
            k += 1
    return k
