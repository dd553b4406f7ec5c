"""Visibility order of convex solids: per-mesh ordering data and the per-frame sort.

What does not depend on the camera is computed once per :class:`Mesh` object
(:func:`prepare`): faces grouped by solid, the decal flag (a face coplanar with an
earlier face of its solid: windows, lights, plates, sign fronts; it adds no plane and
no corner to the solid), each solid's hull planes and hull corners, its bounding
sphere, and each face's plane, centroid and flat colour.

Per frame, :func:`solid_rank` orders the visible solids far to near. Of two solids
whose screen boxes overlap, the one whose camera depth interval lies wholly in front
is in front (along every ray meeting both, the depth of a point grows with its
distance); the other pairs need a separating plane: for two convex solids that do
not intersect, a face plane of one of them separates them, and the solid on the
camera's side of it is in front. Ties and the rare pair that only an edge-edge plane
separates go by distance. Sorting by the far end of the depth interval satisfies
every interval-resolved pair; only when a plane-resolved pair disagrees with that
sort does a topological sort run.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from simroad.camera.mesh import Mesh

__all__ = ["Prepared", "prepare", "solid_rank"]

_PLANE_Q = 1e4  # decal test: normals equal to 1e-4 ...
_OFFSET_Q = 1e3  # ... and plane offsets to 1 mm
_VERTEX_Q = 1e4  # hull corners merged within 0.1 mm


@dataclass(frozen=True)
class Prepared:
    """Camera-independent data of one mesh; faces in solid-major order.

    Attributes (F faces, S solids)
    ------------------------------
    mesh : Mesh
        The mesh (kept so that a cache keyed on its id stays valid).
    face : ndarray int64 (F,)
        Index into ``mesh`` of each face (stable within a solid: mesh order).
    solid : ndarray int64 (F,)
        Index in [0, S) of each face's solid (non-decreasing).
    verts : ndarray float64 (F, vm, 3)
        Corners, padded by repeating the last one.
    normal : ndarray float64 (F, 3)
    offset : ndarray float64 (F,)
        Plane offset ``normal . corner``.
    decal : ndarray bool (F,)
    centroid : ndarray float64 (F, 3)
    reach : ndarray float64 (F,)
        Largest distance (m) from the centroid to a corner.
    sphere : ndarray float64 (S, 4)
        Bounding sphere of every solid: centre and radius (m).
    planes : ndarray float64 (S, hmax, 4)
        Hull planes ``(n, k)`` of every solid; padding ``(0, 0, 0, 1)`` separates nothing.
    corners : ndarray float64 (S, vmax, 3)
        Hull corners of every solid, padded by repeating the first.
    """

    mesh: Mesh
    face: np.ndarray
    solid: np.ndarray
    verts: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    decal: np.ndarray
    centroid: np.ndarray
    reach: np.ndarray
    sphere: np.ndarray
    planes: np.ndarray
    corners: np.ndarray


def _rank_in_group(keys: np.ndarray, n: int) -> np.ndarray:
    """Position of each element within its run of equal ``keys`` (sorted ints in [0, n))."""
    starts = np.searchsorted(keys, np.arange(n))
    return np.arange(len(keys)) - starts[keys]


def prepare(mesh: Mesh) -> Prepared:
    """The camera-independent ordering data of a non-empty ``mesh``."""
    F = len(mesh)
    vm = int(mesh.counts.max())
    face = np.argsort(mesh.solid, kind="stable")
    _, solid = np.unique(mesh.solid[face], return_inverse=True)
    S = int(solid[-1]) + 1
    V = mesh.vertices[face, :vm]
    N = mesh.normal[face]
    k = np.einsum("fc,fc->f", N, V[:, 0])
    counts = mesh.counts[face]
    # Decals: the plane of an earlier face of the same solid.
    q = np.column_stack([solid, np.round(N * _PLANE_Q), np.round(k * _OFFSET_Q)]) + 0.0
    o = np.lexsort(q.T[::-1])  # stable: equal planes keep mesh order
    qs = q[o]
    first = o[np.r_[True, (qs[1:] != qs[:-1]).any(axis=1)]]
    decal = np.ones(F, dtype=bool)
    decal[first] = False
    real = np.arange(vm) < counts[:, None]
    centroid = (V * real[..., None]).sum(axis=1) / counts[:, None]
    reach = np.linalg.norm(V - centroid[:, None], axis=2).max(axis=1)
    # Hull planes.
    hf = np.flatnonzero(~decal)
    hs = solid[hf]
    hr = _rank_in_group(hs, S)
    planes = np.zeros((S, int(hr.max()) + 1, 4))
    planes[..., 3] = 1.0
    planes[hs, hr, :3] = N[hf]
    planes[hs, hr, 3] = k[hf]
    # Hull corners: the distinct corners of the hull faces.
    sel = real[hf]
    pts = V[hf][sel]
    ps = np.repeat(hs, counts[hf])
    key = np.round(pts * _VERTEX_Q).astype(np.int64)
    o = np.lexsort((key[:, 2], key[:, 1], key[:, 0], ps))
    key, pts, ps = key[o], pts[o], ps[o]
    new = np.ones(len(ps), dtype=bool)
    new[1:] = (ps[1:] != ps[:-1]) | (key[1:] != key[:-1]).any(axis=1)
    pts, ps = pts[new], ps[new]
    pr = _rank_in_group(ps, S)
    starts = np.searchsorted(ps, np.arange(S))
    corners = np.repeat(pts[starts][:, None], int(pr.max()) + 1, axis=1)
    corners[ps, pr] = pts
    lo = np.minimum.reduceat(pts, starts)
    hi = np.maximum.reduceat(pts, starts)
    ctr = 0.5 * (lo + hi)
    rad = np.sqrt(np.maximum.reduceat(((pts - ctr[ps]) ** 2).sum(axis=1), starts))
    sphere = np.column_stack([ctr, rad])
    return Prepared(mesh, face, solid, V, N, k, decal, centroid, reach, sphere, planes, corners)


def separated(
    planes: np.ndarray, corners: np.ndarray, C: np.ndarray, a: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """For solid pairs ``(a, b)`` (indices into ``planes`` and ``corners``): whether a
    hull plane of one separates them, and if so whether ``b`` is in front of ``a``."""
    pa, pb = planes[a], planes[b]
    ca, cb = corners[a], corners[b]
    # (P, h, v): all corners of the other solid outside a plane.
    sa = (np.matmul(pa[..., :3], cb.transpose(0, 2, 1)).min(axis=2) - pa[..., 3]) >= -1e-6
    sb = (np.matmul(pb[..., :3], ca.transpose(0, 2, 1)).min(axis=2) - pb[..., 3]) >= -1e-6
    cam_a = pa[..., :3] @ C - pa[..., 3] > 0
    cam_b = pb[..., :3] @ C - pb[..., 3] > 0
    by_a = (sa & cam_a).any(axis=1)  # b beyond a's plane on the camera's side: b in front
    by_b = (sb & ~cam_b).any(axis=1)  # a beyond b's plane away from the camera: b in front
    has_a, has_b = sa.any(axis=1), sb.any(axis=1)
    return has_a | has_b, np.where(has_a, by_a, by_b)


def solid_rank(
    box: np.ndarray, zr: np.ndarray, dist: np.ndarray, planes: np.ndarray, corners: np.ndarray, C: np.ndarray
) -> np.ndarray:
    """Draw rank (0 = first, far to near) of every visible solid.

    Parameters
    ----------
    box : ndarray float (S, 4)
        Screen box of each solid's visible faces: u0, v0, u1, v1 (px).
    zr : ndarray float (S, 2)
        Camera depth interval of those faces (m; may be negative behind the camera).
    dist : ndarray float (S,)
        Distance (m) of each solid from the camera (the tie-break).
    planes, corners : ndarray
        Hull planes (S, h, 4) and hull corners (S, v, 3) in world metres.
    C : ndarray (3,)
        Camera centre in the world.
    """
    S = len(box)
    base = np.lexsort((-dist, -zr[:, 1]))  # farthest far end first
    if S < 2:
        return np.zeros(S, dtype=np.int64)
    ia, ib = np.triu_indices(S, 1)
    ov = (
        (box[ia, 0] <= box[ib, 2])
        & (box[ib, 0] <= box[ia, 2])
        & (box[ia, 1] <= box[ib, 3])
        & (box[ib, 1] <= box[ia, 3])
    )
    ia, ib = ia[ov], ib[ov]
    b_front = zr[ib, 1] < zr[ia, 0]
    open_ = ~b_front & ~(zr[ia, 1] < zr[ib, 0])
    if open_.any():
        pa, pb = ia[open_], ib[open_]
        sep, bf = separated(planes, corners, C, pa, pb)
        b_front[open_] = np.where(sep, bf, dist[pb] < dist[pa])
    src = np.where(b_front, ia, ib)  # drawn first (behind)
    dst = np.where(b_front, ib, ia)
    rank = np.empty(S, dtype=np.int64)
    rank[base] = np.arange(S)
    if not len(src) or bool((rank[src] < rank[dst]).all()):
        return rank
    return _topological(S, src, dst, rank)


def _topological(S: int, src: np.ndarray, dst: np.ndarray, pref: np.ndarray) -> np.ndarray:
    """Kahn's sort of the edges ``src -> dst``, preferring low ``pref``; a cycle (not
    possible for separable solids) is broken at its most preferred solid."""
    succ: list[list[int]] = [[] for _ in range(S)]
    for a, b in zip(src.tolist(), dst.tolist()):
        succ[a].append(b)
    indeg = np.bincount(dst, minlength=S).tolist()
    pl = pref.tolist()
    heap = [(pl[s], s) for s in range(S) if indeg[s] == 0]
    heapq.heapify(heap)
    rank = [-1] * S
    done = 0
    while done < S:
        if not heap:
            s = min((t for t in range(S) if rank[t] < 0), key=lambda t: pl[t])
            indeg[s] = 0
            heap.append((pl[s], s))
        _, s = heapq.heappop(heap)
        if rank[s] >= 0:
            continue
        rank[s] = done
        done += 1
        for d in succ[s]:
            indeg[d] -= 1
            if indeg[d] == 0 and rank[d] < 0:
                heapq.heappush(heap, (pl[d], d))
    return np.asarray(rank, dtype=np.int64)
