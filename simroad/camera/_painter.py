"""Paint a :class:`~simroad.camera.mesh.Mesh` into a camera frame, with exact occlusion.

Every vertex of every face is projected in one matrix operation; back faces (outward
normal away from the camera), faces beyond the range and faces off the image are
culled with numpy; faces crossing the near plane are clipped (the only per-face
Python besides the fill). Solids are drawn far to near in a *visibility order*: for
two convex solids that do not intersect and overlap on screen, a face plane of one
of them separates them (checked for every such pair at once), and the solid on the
camera's side of that plane is in front along every ray that meets both. A
topological sort of these pairwise orders (ties and the rare pair that only an
edge-edge plane separates: by distance) gives the painter's order; faces of one
solid follow mesh order, so decals (windows, lights) land on their base face.

Each visible face is filled with its index into a face-id buffer (one
``cv2.fillConvexPoly`` per face); colour, material and depth then come by lookup
through that buffer. Depth is exact per pixel: the horizontal distance from the
camera to where the pixel's ray meets the face's plane.
"""

from __future__ import annotations

import heapq

import cv2
import numpy as np

from simroad.camera.geometry import PinholeCamera
from simroad.camera.lighting import radiance
from simroad.camera.mesh import Mesh

__all__ = ["NEAR_M", "MeshPainter", "clip_near", "face_colours"]

#: Near clipping plane, metres in front of the camera.
NEAR_M = 0.3
_SHIFT = 4  # fixed-point bits of cv2.fillConvexPoly
_EPS_M = 1e-6


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
    """

    def __init__(self, camera: PinholeCamera) -> None:
        self.camera = camera
        c = camera.config
        K = camera.K
        u = (np.arange(c.width, dtype=np.float64) - K[0, 2]) / K[0, 0]
        v = (np.arange(c.height, dtype=np.float64) - K[1, 2]) / K[1, 1]
        xn, yn = np.meshgrid(u, v)
        rays = np.stack([xn, yn, np.ones_like(xn)], axis=-1) @ camera._R_ego  # ego frame, per pixel
        self._xn = xn.ravel()
        self._yn = yn.ravel()
        #: horizontal ground distance travelled per unit of camera depth z, per pixel
        self._hd = np.hypot(rays[..., 0], rays[..., 1]).ravel()

    # ------------------------------------------------------------ transforms
    def _to_camera(self, xyz: np.ndarray) -> np.ndarray:
        cam = self.camera
        ego2 = (xyz[..., :2] - cam._pos) @ cam._R_we2.T
        ego = np.concatenate([ego2, -xyz[..., 2:3]], axis=-1)
        return (ego - cam._cam_ego) @ cam._R_ego.T

    def _dir_to_camera(self, n: np.ndarray) -> np.ndarray:
        cam = self.camera
        ego = np.concatenate([n[:, :2] @ cam._R_we2.T, -n[:, 2:3]], axis=-1)
        return ego @ cam._R_ego.T

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
            sRGB colour of each face; :func:`face_colours` when omitted.

        Returns
        -------
        ndarray int32 (H, W)
            Index into ``mesh`` of the face each pixel sees; -1 where none.
        """
        c = self.camera.config
        H, W = c.height, c.width
        fid = np.full((H, W), -1, dtype=np.int32)
        plan = self._plan(mesh)
        if plan is None:
            return fid
        items, plane_n, plane_k, dmax = plan
        for f, pts in items:
            cv2.fillConvexPoly(fid, pts, f, lineType=cv2.LINE_8, shift=_SHIFT)
        flat = fid.ravel()
        idx = np.flatnonzero(flat >= 0)
        if not len(idx):
            return fid
        ff = flat[idx]
        if colours is None:
            colours = face_colours(mesh)
        rgb.reshape(-1, 3)[idx] = colours[ff]
        material.reshape(-1)[idx] = mesh.material[ff]
        n = plane_n[ff]
        den = n[:, 0] * self._xn[idx] + n[:, 1] * self._yn[idx] + n[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = self._hd[idx] * plane_k[ff] / den
        # The farthest point of a face is a corner; grazing rays must not exceed it.
        d = np.clip(np.nan_to_num(d, nan=0.0, posinf=0.0, neginf=0.0), 0.0, dmax[ff])
        depth.reshape(-1)[idx] = d
        return fid

    # ------------------------------------------------------------------ plan
    def _plan(self, mesh: Mesh):
        """Cull, clip, project and order; ``None`` when nothing is visible."""
        F = len(mesh)
        if F == 0:
            return None
        cam = self.camera
        c = cam.config
        cx, cy = cam.position_world
        C = np.array([cx, cy, c.mount_height_m])
        V, counts = mesh.vertices, mesh.counts
        front = np.einsum("fc,fc->f", mesh.normal, C - V[:, 0]) > _EPS_M
        near_xy = np.hypot(V[:, :, 0] - cx, V[:, :, 1] - cy).min(axis=1)
        front &= near_xy <= c.max_range_m
        cand = np.flatnonzero(front)
        if not len(cand):
            return None
        P = self._to_camera(V[cand])  # (n, 16, 3)
        z = P[..., 2]
        zmin, zmax = z.min(axis=1), z.max(axis=1)
        K = cam.K
        fx, fy, px, py = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        keep = zmax >= NEAR_M
        polys: dict[int, np.ndarray] = {}
        lo = np.full((len(cand), 2), np.inf)
        hi = np.full((len(cand), 2), -np.inf)
        inside = keep & (zmin >= NEAR_M)
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([fx * P[..., 0] / z + px, fy * P[..., 1] / z + py], axis=-1)
        lo[inside] = uv[inside].min(axis=1)
        hi[inside] = uv[inside].max(axis=1)
        for k in np.flatnonzero(keep & ~inside):  # faces crossing the near plane
            pc = clip_near(P[k, : counts[cand[k]]])
            if len(pc) < 3:
                keep[k] = False
                continue
            q = np.column_stack([fx * pc[:, 0] / pc[:, 2] + px, fy * pc[:, 1] / pc[:, 2] + py])
            polys[int(cand[k])] = np.round(q * (1 << _SHIFT)).astype(np.int32)
            lo[k], hi[k] = q.min(axis=0), q.max(axis=0)
        keep &= (hi[:, 0] >= -0.5) & (lo[:, 0] <= c.width - 0.5) & (hi[:, 1] >= -0.5) & (lo[:, 1] <= c.height - 0.5)
        sel = np.flatnonzero(keep)
        if not len(sel):
            return None
        faces = cand[sel]
        fixed = np.round(uv[sel] * (1 << _SHIFT)).astype(np.int32)
        for j, f in enumerate(faces.tolist()):
            if f not in polys:
                polys[f] = fixed[j, : counts[f]]
        # Plane of each face in camera coordinates: n_c . X = k_c.
        plane_n = np.zeros((F, 3))
        plane_k = np.zeros(F)
        nc = self._dir_to_camera(mesh.normal[faces])
        plane_n[faces] = nc
        plane_k[faces] = np.einsum("fc,fc->f", nc, P[sel, 0])
        dmax = np.zeros(F)
        dmax[faces] = np.hypot(V[faces, :, 0] - cx, V[faces, :, 1] - cy).max(axis=1)
        rank = _solid_order(mesh, faces, lo[sel], hi[sel], C)
        order = faces[np.lexsort((faces, rank))]
        return [(f, polys[f]) for f in order.tolist()], plane_n, plane_k, dmax


def _solid_order(mesh: Mesh, faces: np.ndarray, lo: np.ndarray, hi: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Draw rank (0 = first) of the solid of each of ``faces`` (far to near)."""
    sids, inv = np.unique(mesh.solid[faces], return_inverse=True)
    S = len(sids)
    if S == 1:
        return np.zeros(len(faces), dtype=np.int64)
    # Screen box and distance of every visible solid.
    slo = np.full((S, 2), np.inf)
    shi = np.full((S, 2), -np.inf)
    np.minimum.at(slo, inv, lo)
    np.maximum.at(shi, inv, hi)
    allf = np.flatnonzero(np.isin(mesh.solid, sids))
    sidx = np.searchsorted(sids, mesh.solid[allf])
    cen = mesh.vertices[allf].mean(axis=1)
    ctr = np.zeros((S, 3))
    np.add.at(ctr, sidx, cen)
    ctr /= np.bincount(sidx, minlength=S)[:, None]
    dist = np.linalg.norm(ctr - C, axis=1)
    ia, ib = np.triu_indices(S, 1)
    ov = (slo[ia, 0] <= shi[ib, 0]) & (slo[ib, 0] <= shi[ia, 0]) & (slo[ia, 1] <= shi[ib, 1]) & (slo[ib, 1] <= shi[ia, 1])
    ia, ib = ia[ov], ib[ov]
    succ: list[list[int]] = [[] for _ in range(S)]
    indeg = np.zeros(S, dtype=np.int64)
    if len(ia):
        b_front = _b_in_front(mesh, allf, sidx, S, ia, ib, C, dist)
        src = np.where(b_front, ia, ib)  # drawn first (behind)
        dst = np.where(b_front, ib, ia)
        for s, d in zip(src.tolist(), dst.tolist()):
            succ[s].append(d)
        indeg = np.bincount(dst, minlength=S)
    indeg_l = indeg.tolist()
    heap = [(-dist[s], s) for s in range(S) if indeg_l[s] == 0]
    heapq.heapify(heap)
    rank = np.full(S, -1, dtype=np.int64)
    done = 0
    while done < S:
        if not heap:  # a cycle (not possible for separable solids): break it by distance
            rest = np.flatnonzero(rank < 0)
            s = int(rest[np.argmax(dist[rest])])
            indeg_l[s] = 0
            heap.append((-dist[s], s))
        _, s = heapq.heappop(heap)
        if rank[s] >= 0:
            continue
        rank[s] = done
        done += 1
        for d in succ[s]:
            indeg_l[d] -= 1
            if indeg_l[d] == 0 and rank[d] < 0:
                heapq.heappush(heap, (-dist[d], d))
    return rank[inv]


def _b_in_front(
    mesh: Mesh,
    allf: np.ndarray,
    sidx: np.ndarray,
    S: int,
    ia: np.ndarray,
    ib: np.ndarray,
    C: np.ndarray,
    dist: np.ndarray,
) -> np.ndarray:
    """For solid pairs ``(ia, ib)``: is ``ib`` in front of ``ia`` where they overlap?"""
    order = np.argsort(sidx, kind="stable")
    fs, ss = allf[order], sidx[order]
    starts = np.searchsorted(ss, np.arange(S))
    frank = np.arange(len(fs)) - starts[ss]
    fmax = int(frank.max()) + 1
    normal = mesh.normal[fs]
    planes = np.zeros((S, fmax, 4))
    planes[..., 3] = 1.0  # padding: a plane that separates nothing (n . v - k = -1)
    planes[ss, frank, :3] = normal
    planes[ss, frank, 3] = np.einsum("fc,fc->f", normal, mesh.vertices[fs, 0])
    # Corners of every solid (padding repeats the solid's first corner).
    cnt = mesh.counts[fs]
    vm = np.arange(mesh.vertices.shape[1])[None, :] < cnt[:, None]
    vs = np.repeat(ss, cnt)
    pts = mesh.vertices[fs][vm]
    vstart = np.searchsorted(vs, np.arange(S))
    vrank = np.arange(len(vs)) - vstart[vs]
    vmax = int(vrank.max()) + 1
    verts = np.repeat(pts[vstart][:, None, :], vmax, axis=1)
    verts[vs, vrank] = pts
    side_c = planes[..., :3] @ C - planes[..., 3]  # (S, fmax): > 0 camera outside
    cam_out = side_c > 0

    def separating(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = np.matmul(planes[a, :, :3], verts[b].transpose(0, 2, 1)) - planes[a, :, 3:4]
        return d.min(axis=2) >= -1e-6  # (P, fmax): all of b outside a's plane

    sa = separating(ia, ib)
    sb = separating(ib, ia)
    # A plane of a with b outside: b is in front iff the camera is outside it too.
    by_a = (sa & cam_out[ia]).any(axis=1)
    found_a = sa.any(axis=1)
    by_b = (sb & ~cam_out[ib]).any(axis=1)
    found_b = sb.any(axis=1)
    return np.where(found_a, by_a, np.where(found_b, by_b, dist[ib] < dist[ia]))
