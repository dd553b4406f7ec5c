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
        self._xn = xn.ravel().astype(np.float32)
        self._yn = yn.ravel().astype(np.float32)
        #: horizontal ground distance travelled per unit of camera depth z, per pixel
        self._hd = np.hypot(rays[..., 0], rays[..., 1]).ravel().astype(np.float32)

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
        items, coef, dmax = plan
        for f, pts in items:
            cv2.fillConvexPoly(fid, pts, f, lineType=cv2.LINE_8, shift=_SHIFT)
        flat = fid.ravel()
        idx = np.flatnonzero(flat >= 0)
        if not len(idx):
            return fid
        ff = flat[idx]
        if colours is None:
            colours = face_colours(mesh)
        px = rgb.reshape(-1, 3)
        for ch in range(3):  # one channel at a time: three times faster than rows
            px[idx, ch] = colours[ff, ch]
        material.reshape(-1)[idx] = mesh.material[ff]
        # depth = hd / (a xn + b yn + c): the ray meets the face's plane (a, b, c per face)
        den = coef[0][ff] * self._xn[idx] + coef[1][ff] * self._yn[idx] + coef[2][ff]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = self._hd[idx] / den
        # The farthest point of a face is a corner; grazing rays must not exceed it.
        d = np.nan_to_num(d, nan=0.0, posinf=0.0, neginf=0.0)
        np.clip(d, 0.0, dmax[ff], out=d)
        depth.reshape(-1)[idx] = d
        return fid

    # ------------------------------------------------------------------ plan
    def _plan(self, mesh: Mesh):
        """Cull, clip, project and order; ``None`` when nothing is visible.

        Returns ``(items, coef, dmax)``: the faces to fill in drawing order as
        ``(face index, int32 fixed-point polygon)``, and per face of the mesh its
        camera-frame plane ``n . X = k`` as ``n / k`` (3, F) and the farthest corner's
        horizontal distance.
        """
        F = len(mesh)
        if F == 0:
            return None
        cam = self.camera
        c = cam.config
        cx, cy = cam.position_world
        C = np.array([cx, cy, c.mount_height_m])
        counts = mesh.counts
        vm = int(counts.max())
        V = mesh.vertices[:, :vm]  # the padding repeats the last corner: drop it
        front = np.einsum("fc,fc->f", mesh.normal, C - V[:, 0]) > _EPS_M
        hxy = np.hypot(V[..., 0] - cx, V[..., 1] - cy)
        front &= hxy.min(axis=1) <= c.max_range_m
        cand = np.flatnonzero(front)
        if not len(cand):
            return None
        P = self._to_camera(V[cand])  # (n, vm, 3)
        z = P[..., 2]
        zmin, zmax = z.min(axis=1), z.max(axis=1)
        K = cam.K
        fx, fy, px, py = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        keep = zmax >= NEAR_M
        inside = keep & (zmin >= NEAR_M)
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([fx * P[..., 0] / z + px, fy * P[..., 1] / z + py], axis=-1)
        lo = uv.min(axis=1)
        hi = uv.max(axis=1)
        clipped: dict[int, np.ndarray] = {}
        for k in np.flatnonzero(keep & ~inside).tolist():  # faces crossing the near plane
            pc = clip_near(P[k, : counts[cand[k]]])
            if len(pc) < 3:
                keep[k] = False
                continue
            q = np.column_stack([fx * pc[:, 0] / pc[:, 2] + px, fy * pc[:, 1] / pc[:, 2] + py])
            clipped[int(cand[k])] = np.round(q * (1 << _SHIFT)).astype(np.int32)
            lo[k], hi[k] = q.min(axis=0), q.max(axis=0)
        keep &= (hi[:, 0] >= -0.5) & (lo[:, 0] <= c.width - 0.5) & (hi[:, 1] >= -0.5) & (lo[:, 1] <= c.height - 0.5)
        sel = np.flatnonzero(keep)
        if not len(sel):
            return None
        faces = cand[sel]
        fixed = np.round(np.nan_to_num(uv[sel]) * (1 << _SHIFT)).astype(np.int32)
        # Plane of each face in camera coordinates, n . X = k, as n / k (k != 0: the
        # camera sees the face, so it is not in its plane).
        coef = np.zeros((3, F), dtype=np.float32)
        nc = self._dir_to_camera(mesh.normal[faces])
        coef[:, faces] = (nc / np.einsum("fc,fc->f", nc, P[sel, 0])[:, None]).T
        dmax = np.zeros(F, dtype=np.float32)
        dmax[faces] = hxy[faces].max(axis=1)
        rank = _solid_order(mesh, faces, lo[sel], hi[sel], C)
        pos = np.lexsort((faces, rank))
        items = [(f, clipped[f] if f in clipped else fixed[j]) for f, j in zip(faces[pos].tolist(), pos.tolist())]
        return items, coef, dmax


def _group(keys: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``order`` sorting ``keys`` (ints in [0, n)) stably, and each key's start in it."""
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(n))
    return order, starts


def _solid_order(mesh: Mesh, faces: np.ndarray, lo: np.ndarray, hi: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Draw rank (0 = first) of the solid of each of ``faces`` (far to near)."""
    sids, inv = np.unique(mesh.solid[faces], return_inverse=True)
    S = len(sids)
    if S == 1:
        return np.zeros(len(faces), dtype=np.int64)
    # Screen box of every visible solid.
    order, starts = _group(inv, S)
    slo = np.minimum.reduceat(lo[order], starts)
    shi = np.maximum.reduceat(hi[order], starts)
    ia, ib = np.triu_indices(S, 1)
    ov = (
        (slo[ia, 0] <= shi[ib, 0])
        & (slo[ib, 0] <= shi[ia, 0])
        & (slo[ia, 1] <= shi[ib, 1])
        & (slo[ib, 1] <= shi[ia, 1])
    )
    ia, ib = ia[ov], ib[ov]
    # Distance of every solid's centre (the tie-break).
    allf = np.flatnonzero(np.isin(mesh.solid, sids))
    sidx = np.searchsorted(sids, mesh.solid[allf])
    cen = mesh.vertices[allf, 0]
    n_f = np.bincount(sidx, minlength=S)
    ctr = np.column_stack([np.bincount(sidx, cen[:, k], minlength=S) for k in range(3)]) / n_f[:, None]
    dist = np.linalg.norm(ctr - C, axis=1)
    if not len(ia):
        return np.argsort(np.argsort(-dist, kind="stable"))[inv]
    b_front = _b_in_front(mesh, allf, sidx, S, ia, ib, C, dist)
    src = np.where(b_front, ia, ib).tolist()  # drawn first (behind)
    dst = np.where(b_front, ib, ia)
    succ: list[list[int]] = [[] for _ in range(S)]
    for a, b in zip(src, dst.tolist()):
        succ[a].append(b)
    indeg = np.bincount(dst, minlength=S).tolist()
    dl = (-dist).tolist()
    heap = [(dl[s], s) for s in range(S) if indeg[s] == 0]
    heapq.heapify(heap)
    rank = [-1] * S
    done = 0
    while done < S:
        if not heap:  # a cycle (not possible for separable solids): break it by distance
            s = max((t for t in range(S) if rank[t] < 0), key=lambda t: -dl[t])
            indeg[s] = 0
            heap.append((dl[s], s))
        _, s = heapq.heappop(heap)
        if rank[s] >= 0:
            continue
        rank[s] = done
        done += 1
        for d in succ[s]:
            indeg[d] -= 1
            if indeg[d] == 0 and rank[d] < 0:
                heapq.heappush(heap, (dl[d], d))
    return np.asarray(rank, dtype=np.int64)[inv]


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
    order, starts = _group(sidx, S)
    fs, ss = allf[order], sidx[order]
    frank = np.arange(len(fs)) - starts[ss]
    fmax = int(frank.max()) + 1
    normal = mesh.normal[fs]
    planes = np.zeros((S, fmax, 4))
    planes[..., 3] = 1.0  # padding: a plane that separates nothing (n . v - k = -1)
    planes[ss, frank, :3] = normal
    planes[ss, frank, 3] = np.einsum("fc,fc->f", normal, mesh.vertices[fs, 0])
    # Corners of every solid: the corners of its faces (padding repeats the first).
    vm = int(mesh.counts[fs].max())
    vmax = fmax * vm
    verts = np.repeat(mesh.vertices[fs[starts], :1], vmax, axis=1)
    verts.reshape(S, fmax, vm, 3)[ss, frank] = mesh.vertices[fs, :vm]
    cam_out = planes[..., :3] @ C - planes[..., 3] > 0  # (S, fmax)

    def separating(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = np.matmul(planes[a, :, :3], verts[b].transpose(0, 2, 1)) - planes[a, :, 3:4]
        return d.min(axis=2) >= -1e-6  # (P, fmax): all of b outside a's plane

    sa = separating(ia, ib)
    sb = separating(ib, ia)
    # A plane of a with b outside: b is in front iff the camera is outside it too.
    by_a = (sa & cam_out[ia]).any(axis=1)
    by_b = (sb & ~cam_out[ib]).any(axis=1)
    return np.where(sa.any(axis=1), by_a, np.where(sb.any(axis=1), by_b, dist[ib] < dist[ia]))
