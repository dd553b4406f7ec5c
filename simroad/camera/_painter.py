"""Paint meshes into a camera frame, with exact occlusion between convex solids.

What does not depend on the camera (faces grouped by solid, decal flags, hull planes
and corners, bounding spheres, flat colours) is computed once per
:class:`~simroad.camera.mesh.Mesh` object and cached (:mod:`simroad.camera._occlusion`);
the scenery hands the same mesh object over while the view stays within the same
cells. Per frame, solids outside the view frustum or the range are culled by their
bounding sphere; of the rest, back faces (outward normal away from the camera) and
faces off the image are culled with numpy, and faces crossing the near plane are
clipped (the only per-face Python besides the fill). Level of detail: a face whose
screen box is below one pixel both ways (a decal: 1.5 px) is not drawn. Solids are
drawn far to near in a visibility order (:func:`~simroad.camera._occlusion.solid_rank`);
faces of one solid follow mesh order, so decals (windows, lights) land on their base
face.

Each drawn face is filled with its slot into a face buffer (one ``cv2.fillConvexPoly``
per face, uint8 slots when at most 255 faces are drawn); colour, material and depth
then come by table lookup through that buffer (``cv2.LUT``), only in the rows the
faces cover. Depth is exact per pixel: the horizontal distance from the camera to
where the pixel's ray meets the face's plane.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

import cv2
import numpy as np

from simroad.camera._occlusion import Prepared, prepare, solid_rank
from simroad.camera.geometry import PinholeCamera
from simroad.camera.lighting import radiance
from simroad.camera.mesh import Mesh

__all__ = ["DECAL_LOD_PX", "LOD_PX", "NEAR_M", "MeshPainter", "clip_near", "face_colours"]

#: Near clipping plane, metres in front of the camera.
NEAR_M = 0.3
#: A face whose screen box is below this many pixels both ways is not drawn ...
LOD_PX = 1.0
#: ... and a decal (a face painted over a coplanar face of its solid) below this.
DECAL_LOD_PX = 1.5
_SHIFT = 4  # fixed-point bits of cv2.fillConvexPoly
_EPS_M = 1e-6
_CACHE = 6  # prepared meshes kept (scenery windows, shadow queries, vehicles)


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
    from simroad.noise.radiometry import linear_to_srgb  # the project's gamma (noise imports camera)

    if not len(mesh):
        return np.zeros((0, 3), dtype=np.uint8)
    lin = radiance(mesh.albedo, mesh.normal[:, 2].astype(np.float32))
    return linear_to_srgb(np.ascontiguousarray(lin[None]))[0]


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
        c = camera.config
        K = camera.K
        u = (np.arange(c.width, dtype=np.float64) - K[0, 2]) / K[0, 0]
        v = (np.arange(c.height, dtype=np.float64) - K[1, 2]) / K[1, 1]
        xn, yn = np.meshgrid(u, v)
        rays = np.stack([xn, yn, np.ones_like(xn)], axis=-1) @ camera._R_ego  # ego frame, per pixel
        self._xn = u.astype(np.float32)[None, :]
        self._yn = v.astype(np.float32)[:, None]
        #: horizontal ground distance travelled per unit of camera depth z, per pixel
        self._hd = np.hypot(rays[..., 0], rays[..., 1]).astype(np.float32)
        # Inward normals of the frustum's side planes (camera frame, through the centre).
        xl, xr = (-0.5 - K[0, 2]) / K[0, 0], (c.width - 0.5 - K[0, 2]) / K[0, 0]
        yt, yb = (-0.5 - K[1, 2]) / K[1, 1], (c.height - 0.5 - K[1, 2]) / K[1, 1]
        sides = np.array([[1.0, 0.0, -xl], [-1.0, 0.0, xr], [0.0, 1.0, -yt], [0.0, -1.0, yb]])
        self._sides = sides / np.linalg.norm(sides, axis=1)[:, None]
        self._cache: OrderedDict[int, tuple[Prepared, np.ndarray]] = OrderedDict()

    # ------------------------------------------------------------ transforms
    def _affine(self) -> tuple[np.ndarray, np.ndarray]:
        """``(M, o)`` with camera = world @ M + o (rows: points, world z up)."""
        cam = self.camera
        pts = np.vstack([np.zeros(3), np.eye(3)])
        ego2 = (pts[:, :2] - cam._pos) @ cam._R_we2.T
        cp = (np.column_stack([ego2, -pts[:, 2]]) - cam._cam_ego) @ cam._R_ego.T
        return cp[1:] - cp[0], cp[0]

    def _prepared(self, mesh: Mesh) -> tuple[Prepared, np.ndarray]:
        key = id(mesh)
        hit = self._cache.get(key)
        if hit is not None and hit[0].mesh is mesh:
            self._cache.move_to_end(key)
            return hit
        prep = prepare(mesh)
        out = (prep, face_colours(mesh)[prep.face].astype(np.float32))
        self._cache[key] = out
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return out

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
            Horizontal distance in m from the camera; overwritten where a face is seen.
        colours : ndarray uint8 (F, 3), optional
            sRGB colour of each face; :func:`face_colours` (faded into the haze when
            the painter has one) when omitted.

        Returns
        -------
        ndarray int32 (H, W)
            Index into ``mesh`` of the face each pixel sees; -1 where none.
        """
        fid, drawn = self._paint([mesh], rgb, material, depth, colours)
        table = np.append(drawn[1], -1).astype(np.int32)  # slot k -> face, slot -1 -> none
        return table[fid]

    def paint_parts(
        self, parts: Sequence[Mesh], rgb: np.ndarray, material: np.ndarray, depth: np.ndarray
    ) -> tuple[np.ndarray, Mesh]:
        """Paint several meshes at once (e.g. the scenery and the vehicles, each
        prepared and cached on its own) and return what was drawn.

        Returns
        -------
        face_id : ndarray int32 (H, W)
            Index into ``faces`` of the face each pixel sees; -1 where none.
        faces : Mesh
            The faces drawn, in slot order (solid ids renumbered per part as
            :meth:`Mesh.concat` does).
        """
        parts = [p for p in parts if len(p)]
        fid, (part, face) = self._paint(parts, rgb, material, depth, None)
        sel = []
        for p, m in enumerate(parts):
            mask = part == p
            if mask.any():
                sel.append(m.select(face[mask]))
            else:  # keep the solid renumbering of Mesh.concat
                sel.append(m.select(np.zeros(0, dtype=np.int64)))
        return fid, _concat_keep_offsets(sel, parts)

    # ------------------------------------------------------------------ core
    def _paint(self, parts, rgb, material, depth, colours):
        """Fill the face buffer and look colour, material and depth up through it.

        Returns the face-slot map (int32 (H, W), -1 where none) and ``(part, face)``
        of every slot.
        """
        c = self.camera.config
        H, W = c.height, c.width
        fid = np.full((H, W), -1, dtype=np.int32)
        plan = self._plan(parts, colours) if parts else None
        if plan is None:
            return fid, (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
        polys, col, mat, coef, dmax, rows, origin = plan
        n = len(col)
        r0, r1 = rows
        small = n <= 255
        buf = np.zeros((r1 - r0, W), dtype=np.uint8 if small else np.int32)
        for j, poly in enumerate(polys):
            if isinstance(poly, list):
                cv2.fillPoly(buf, poly, j + 1, lineType=cv2.LINE_8, shift=_SHIFT)
            else:
                cv2.fillConvexPoly(buf, poly, j + 1, lineType=cv2.LINE_8, shift=_SHIFT)

        def look(table: np.ndarray, none: float = 0) -> np.ndarray:
            table = np.concatenate([np.full((1, *table.shape[1:]), none, table.dtype), table])
            if small:
                t = np.zeros((256, *table.shape[1:]), table.dtype)
                t[: n + 1] = table
                return cv2.LUT(buf, t)
            return table[buf]

        on = buf > 0
        fid[r0:r1] = look(np.arange(n, dtype=np.int32), -1)
        if small:
            lut = np.zeros((256, 1, 3), dtype=np.uint8)
            lut[1 : n + 1, 0] = col
            obj = cv2.LUT(cv2.merge([buf, buf, buf]), lut)
        else:
            obj = np.concatenate([np.zeros((1, 3), np.uint8), col])[buf]
        np.copyto(rgb[r0:r1], obj, where=on[..., None])
        np.copyto(material[r0:r1], look(mat), where=on)
        # depth = hd / (a xn + b yn + c): the ray meets the face's plane (a, b, c per face)
        den = look(coef[:, 0]) * self._xn
        den += look(coef[:, 1]) * self._yn[r0:r1]
        den += look(coef[:, 2])
        np.maximum(den, 1e-9, out=den)
        d = self._hd[r0:r1] / den
        # The farthest point of a face is a corner; grazing rays must not exceed it.
        np.minimum(d, look(dmax), out=d)
        np.copyto(depth[r0:r1], d, where=on)
        return fid, origin

    # ------------------------------------------------------------------ plan
    def _plan(self, parts: Sequence[Mesh], colours: np.ndarray | None):
        """Cull, clip, project, level-of-detail and order; ``None`` when nothing shows.

        Returns ``(pts, order, colour, material, coef, dmax, rows, origin)`` over the
        drawn faces: int32 fixed-point polygons, the drawing order, uint8 colours
        (n, 3), materials (n,), camera-frame planes ``n . X = k`` as ``n / k`` (n, 3),
        the farthest corner's horizontal distance (n,), the rows ``(r0, r1)`` they
        cover, and ``(part, face index in its mesh)``.
        """
        cam = self.camera
        c = cam.config
        R = c.max_range_m
        cx, cy = cam.position_world
        C = np.array([cx, cy, c.mount_height_m])
        M, o = self._affine()
        sel: list[tuple[int, Prepared, np.ndarray, np.ndarray]] = []
        for p, mesh in enumerate(parts):
            prep, col = self._prepared(mesh)
            sph = prep.sphere
            sc = sph[:, :3] @ M + o
            r = sph[:, 3]
            vis = (sc[:, 2] + r >= NEAR_M) & ((sc @ self._sides.T) >= -r[:, None]).all(axis=1)
            vis &= np.hypot(sph[:, 0] - cx, sph[:, 1] - cy) - r <= R
            cand = np.flatnonzero(vis[prep.solid] & (prep.normal @ C - prep.offset > _EPS_M))
            if len(cand):  # face spheres: in the frustum and not below the decal LOD
                fc = prep.centroid[cand] @ M + o
                fr = prep.reach[cand]
                ok = (fc[:, 2] + fr >= NEAR_M) & ((fc @ self._sides.T) >= -fr[:, None]).all(axis=1)
                tiny = 2.0 * self.camera.K[0, 0] * fr < DECAL_LOD_PX * (fc[:, 2] - fr)
                cand = cand[ok & ~(tiny & prep.decal[cand])]
            if len(cand):
                if colours is not None:
                    col = np.asarray(colours, dtype=np.float32)[prep.face]
                sel.append((p, prep, cand, col))
        if not sel:
            return None
        vm = max(s[1].verts.shape[1] for s in sel)
        V = np.concatenate([_pad(s[1].verts[s[2]], vm) for s in sel])
        counts = np.concatenate([s[1].mesh.counts[s[1].face[s[2]]] for s in sel])
        hxy = np.hypot(V[..., 0] - cx, V[..., 1] - cy)
        P = V @ M + o  # (n, vm, 3)
        z = P[..., 2]
        zmin, zmax = z.min(axis=1), z.max(axis=1)
        K = cam.K
        fx, fy, px, py = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        keep = (zmax >= NEAR_M) & (hxy.min(axis=1) <= R)
        inside = keep & (zmin >= NEAR_M)
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([fx * P[..., 0] / z + px, fy * P[..., 1] / z + py], axis=-1)
        lo = uv.min(axis=1)
        hi = uv.max(axis=1)
        clipped: dict[int, np.ndarray] = {}
        for k in np.flatnonzero(keep & ~inside).tolist():  # faces crossing the near plane
            pc = clip_near(P[k, : counts[k]])
            if len(pc) < 3:
                keep[k] = False
                continue
            q = np.column_stack([fx * pc[:, 0] / pc[:, 2] + px, fy * pc[:, 1] / pc[:, 2] + py])
            clipped[k] = np.round(q * (1 << _SHIFT)).astype(np.int32)
            lo[k], hi[k] = q.min(axis=0), q.max(axis=0)
        keep &= (hi[:, 0] >= -0.5) & (lo[:, 0] <= c.width - 0.5) & (hi[:, 1] >= -0.5) & (lo[:, 1] <= c.height - 0.5)
        decal = np.concatenate([s[1].decal[s[2]] for s in sel])
        size = (hi - lo).max(axis=1)
        keep &= size >= np.where(decal, DECAL_LOD_PX, LOD_PX)
        keep_idx = np.flatnonzero(keep)
        if not len(keep_idx):
            return None
        # Per kept face: its part, its solid (global index) and its data.
        part = np.concatenate([np.full(len(s[2]), s[0]) for s in sel])[keep_idx]
        offs = np.cumsum([0] + [len(s[1].sphere) for s in sel])
        gsol = np.concatenate([s[1].solid[s[2]] + offs[i] for i, s in enumerate(sel)])[keep_idx]
        face = np.concatenate([s[1].face[s[2]] for s in sel])[keep_idx]
        col = np.concatenate([s[3][s[2]] for s in sel])[keep_idx]
        mat = np.concatenate([s[1].mesh.material[s[1].face[s[2]]] for s in sel])[keep_idx]
        normal = np.concatenate([s[1].normal[s[2]] for s in sel])[keep_idx]
        offset = np.concatenate([s[1].offset[s[2]] for s in sel])[keep_idx]
        col_pre = col.astype(np.uint8)
        lo, hi, P, hxy = lo[keep_idx], hi[keep_idx], P[keep_idx], hxy[keep_idx]
        zmin, zmax = zmin[keep_idx], zmax[keep_idx]
        if self.haze is not None:
            cen = np.concatenate([s[1].centroid[s[2]] for s in sel])[keep_idx]
            d = np.hypot(cen[:, 0] - cx, cen[:, 1] - cy)
            t = np.clip((d - 0.6 * R) / (0.4 * R), 0.0, 1.0)[:, None].astype(np.float32)
            col = col + (t * t * (3 - 2 * t)) * (self.haze - col)
        col = np.clip(col, 0, 255).astype(np.uint8)
        # Plane of each face in camera coordinates, n . X = k, as n / k (k != 0: the
        # camera sees the face, so it is not in its plane).
        nc = normal @ M
        coef = (nc / np.einsum("fc,fc->f", nc, P[:, 0])[:, None]).astype(np.float32)
        dmax = hxy.max(axis=1).astype(np.float32)
        # Visibility order of the solids (faces are grouped by gsol, in order).
        starts = np.flatnonzero(np.r_[True, gsol[1:] != gsol[:-1]])
        inv = np.cumsum(np.r_[False, gsol[1:] != gsol[:-1]])
        box = np.column_stack([np.minimum.reduceat(lo, starts), np.maximum.reduceat(hi, starts)])
        zr = np.column_stack([np.minimum.reduceat(zmin, starts), np.maximum.reduceat(zmax, starts)])
        us = gsol[starts]
        owner = np.searchsorted(offs, us, side="right") - 1
        planes, corners, sphere = _solid_data([s[1] for s in sel], owner, us - offs[owner])
        dist = np.linalg.norm(sphere[:, :3] - C, axis=1)
        rank = solid_rank(box, zr, dist, planes, corners, C)
        o_ = np.argsort(rank[inv], kind="stable")  # drawing order of the kept faces
        fixed = np.round(np.nan_to_num(uv[keep_idx]) * (1 << _SHIFT)).astype(np.int32)
        H = c.height
        r0 = int(np.clip(np.floor(lo[:, 1].min()) - 1, 0, H))
        r1 = int(np.clip(np.ceil(hi[:, 1].max()) + 2, r0, H))
        fixed[..., 1] -= r0 << _SHIFT
        pts = list(fixed)
        for j, k in enumerate(keep_idx.tolist()):
            if k in clipped:
                pts[j] = clipped[k] - np.array([0, r0 << _SHIFT], dtype=np.int32)
        # A run of decals of one solid, plane, colour and material (a facade's windows)
        # is one slot, filled by one cv2.fillPoly (they are disjoint).
        dc, g, cq, mt = decal[keep_idx][o_], gsol[o_], col_pre[o_], mat[o_]
        nr, of = normal[o_], offset[o_]
        same = np.zeros(len(o_), dtype=bool)
        same[1:] = (
            dc[1:]
            & dc[:-1]
            & (g[1:] == g[:-1])
            & (mt[1:] == mt[:-1])
            & (cq[1:] == cq[:-1]).all(axis=1)
            & (np.abs(of[1:] - of[:-1]) < 1e-3)
            & (np.einsum("fc,fc->f", nr[1:], nr[:-1]) > 1 - 1e-6)
        )
        first = np.flatnonzero(~same)
        rep = o_[first]
        groups = [o_[a:b].tolist() for a, b in zip(first.tolist(), [*first[1:].tolist(), len(o_)])]
        polys = [pts[m[0]] if len(m) == 1 else [pts[i] for i in m] for m in groups]
        dmax_g = np.maximum.reduceat(dmax[o_], first)
        return polys, col[rep], mat[rep], coef[rep], dmax_g, (r0, r1), (part[rep], face[rep])


def _pad(a: np.ndarray, n: int) -> np.ndarray:
    """Pad axis 1 of ``a`` to ``n`` by repeating its last entry."""
    if a.shape[1] == n:
        return a
    return np.concatenate([a, np.repeat(a[:, -1:], n - a.shape[1], axis=1)], axis=1)


def _solid_data(preps: list[Prepared], owner: np.ndarray, local: np.ndarray):
    """Hull planes, hull corners and bounding spheres of solids ``local`` of ``preps[owner]``."""
    if len(preps) == 1:
        p = preps[0]
        return p.planes[local], p.corners[local], p.sphere[local]
    h = max(p.planes.shape[1] for p in preps)
    v = max(p.corners.shape[1] for p in preps)
    planes = np.zeros((len(local), h, 4))
    planes[..., 3] = 1.0
    corners = np.zeros((len(local), v, 3))
    sphere = np.zeros((len(local), 4))
    for i, p in enumerate(preps):
        m = owner == i
        if m.any():
            planes[m, : p.planes.shape[1]] = p.planes[local[m]]
            corners[m] = _pad(p.corners[local[m]], v)
            sphere[m] = p.sphere[local[m]]
    return planes, corners, sphere


def _concat_keep_offsets(sel: list[Mesh], parts: list[Mesh]) -> Mesh:
    """:meth:`Mesh.concat` of ``sel`` with the solid offsets ``parts`` would get."""
    if not sel:
        return Mesh.empty()
    off, out = 0, []
    for s, p in zip(sel, parts):
        if len(s):
            out.append(Mesh(s.vertices, s.counts, s.albedo, s.material, s.normal, s.solid + off))
        off += int(p.solid.max()) + 1
    if not out:
        return Mesh.empty()
    return Mesh(*(np.concatenate([getattr(m, f) for m in out]) for f in Mesh.__dataclass_fields__))
