"""Compiled kernels of the mesh painter: a z-buffer rasteriser of planar convex faces.

Compiled with numba (``cache=True``: the machine code is stored next to this module
and re-used by later processes and workers). Three kernels:

* :func:`mesh_data` (once per mesh): each face's plane offset, centroid and decal
  flag (coplanar with an earlier face of its solid) and each solid's bounding sphere;
* :func:`rasterise` (per frame and mesh): culls solids by bounding sphere against the
  view frustum and the range, culls back faces, faces beyond the range and faces
  below the level of detail, clips faces to the near plane, projects them and fills
  them scanline by scanline with a per-pixel depth test;
* :func:`face_table` and :func:`shade` (per frame): colour and material through the
  face buffer, which becomes the face map.

Depth is exact per pixel: the horizontal distance from the camera to where the
pixel's ray meets the face's plane ``n . X = k`` (camera frame), ``hd / (n / k . ray)``
with ``hd`` the horizontal distance per unit of camera depth of the pixel's ray
(computed per pixel: no table to fetch).
A face wins a pixel when it is nearer than what the pixel sees (the flat ground's
depth, ``inf`` for the sky, or an earlier face); a later face of the same solid also
wins a tie (0.1 %): the faces of a convex solid that face the camera never overlap,
so an overlap within one solid is a decal (window, light, plate) over its base face.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simroad.core.radiometry import GAMMA

__all__ = ["contact_shadows", "face_table", "fade", "footprints", "mesh_data", "rasterise", "shade"]

#: fast-math flags: no ``nnan``/``ninf`` (the sky's depth is inf)
_FAST = {"nsz", "arcp", "contract", "afn"}
_TIE = 1e-3  # relative depth tolerance of a decal over its base face
_MAXV = 17  # vertices of a near-clipped face (16, one more where the plane cuts)
_BAND = 32  # rows filled together


@njit(cache=True, error_model="numpy")
def mesh_data(verts, counts, normal, solid):  # pragma: no cover - compiled
    """Per-face ``offset (F,)``, ``centroid (F, 3)``, ``decal (F,)`` and per-solid
    ``sphere (S, 4)`` (centre, radius; S = max solid id + 1)."""
    F = verts.shape[0]
    S = 0
    for f in range(F):
        S = max(S, solid[f] + 1)
    offset = np.empty(F)
    centroid = np.zeros((F, 3))
    decal = np.zeros(F, dtype=np.bool_)
    lo = np.full((S, 3), np.inf)
    hi = np.full((S, 3), -np.inf)
    for f in range(F):
        n = counts[f]
        offset[f] = normal[f, 0] * verts[f, 0, 0] + normal[f, 1] * verts[f, 0, 1] + normal[f, 2] * verts[f, 0, 2]
        s = solid[f]
        for i in range(n):
            for a in range(3):
                v = verts[f, i, a]
                centroid[f, a] += v / n
                lo[s, a] = min(lo[s, a], v)
                hi[s, a] = max(hi[s, a], v)
        # Decal: coplanar with an earlier face of its solid (solids are contiguous runs).
        j = f - 1
        while j >= 0 and solid[j] == s and f - j <= 512:
            dot = normal[f, 0] * normal[j, 0] + normal[f, 1] * normal[j, 1] + normal[f, 2] * normal[j, 2]
            if dot > 1.0 - 1e-6 and abs(offset[f] - offset[j]) < 1e-3:
                decal[f] = True
                break
            j -= 1
    sphere = np.zeros((S, 4))
    sphere[:, 3] = -1.0  # no face: never visible
    for s in range(S):
        if lo[s, 0] <= hi[s, 0]:
            for a in range(3):
                sphere[s, a] = 0.5 * (lo[s, a] + hi[s, a])
    for f in range(F):
        s = solid[f]
        for i in range(counts[f]):
            d = 0.0
            for a in range(3):
                d += (verts[f, i, a] - sphere[s, a]) ** 2
            sphere[s, 3] = max(sphere[s, 3], np.sqrt(d))
    return offset, centroid, decal, sphere


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def rasterise(
    verts, counts, normal, offset, solid, decal, sphere, M, o, cam, sides, xn, yn, ray,
    zbuf, fbuf, face_base, lod, decal_lod,
):  # pragma: no cover - compiled  # fmt: skip
    """Draw the faces of one mesh into the depth, face and solid buffers (in place).

    ``M, o``: camera = world @ M + o; ``cam``: ``(fx, fy, px, py, near, range, cx, cy,
    cz)`` with ``(cx, cy, cz)`` the camera's world position; ``sides``: the inward
    normals (4, 3) of the frustum's side planes; ``xn (W,)``, ``yn (H,)``: normalised
    image coordinates of the pixel columns and rows; ``ray`` (3, 3): camera to ego
    rotation (a pixel's ray is ``(xn, yn, 1) @ ray``). ``zbuf`` (float32) holds the
    depth, ``fbuf`` (int32) gets ``face_base + f`` (earlier parts' faces are below
    ``face_base``). Returns the flags (F,) of the faces drawn
    (that passed culling and the level of detail) and the rows ``(r0, r1)`` touched.
    """
    fx, fy, px, py, near, R, cx, cy, cz = cam[0], cam[1], cam[2], cam[3], cam[4], cam[5], cam[6], cam[7], cam[8]
    H, W = zbuf.shape
    F = verts.shape[0]
    S = sphere.shape[0]
    used = np.zeros(F, dtype=np.bool_)
    vis = np.zeros(S, dtype=np.bool_)
    for s in range(S):
        r = sphere[s, 3]
        if r < 0 or np.hypot(sphere[s, 0] - cx, sphere[s, 1] - cy) - r > R:
            continue
        c0 = sphere[s, 0] * M[0, 0] + sphere[s, 1] * M[1, 0] + sphere[s, 2] * M[2, 0] + o[0]
        c1 = sphere[s, 0] * M[0, 1] + sphere[s, 1] * M[1, 1] + sphere[s, 2] * M[2, 1] + o[1]
        c2 = sphere[s, 0] * M[0, 2] + sphere[s, 1] * M[1, 2] + sphere[s, 2] * M[2, 2] + o[2]
        if c2 + r < near:
            continue
        ok = True
        for k in range(4):
            if c0 * sides[k, 0] + c1 * sides[k, 1] + c2 * sides[k, 2] < -r:
                ok = False
        vis[s] = ok
    P = np.empty((16, 3))
    Q = np.empty((_MAXV, 3))
    # Faces to fill: screen polygon, vertex count, plane, farthest distance, face.
    UV = np.empty((F, _MAXV, 2))
    NV = np.empty(F, dtype=np.int64)
    PL = np.empty((F, 4))
    FA = np.empty(F, dtype=np.int64)
    n_fill = 0
    for f in range(F):
        if not vis[solid[f]]:
            continue
        if normal[f, 0] * cx + normal[f, 1] * cy + normal[f, 2] * cz - offset[f] <= 1e-6:
            continue  # turned away (or edge-on)
        n = counts[f]
        zmin, zmax, hmin, hmax = np.inf, -np.inf, np.inf, 0.0
        for i in range(n):
            for a in range(3):
                P[i, a] = verts[f, i, 0] * M[0, a] + verts[f, i, 1] * M[1, a] + verts[f, i, 2] * M[2, a] + o[a]
            zmin = min(zmin, P[i, 2])
            zmax = max(zmax, P[i, 2])
            h = np.hypot(verts[f, i, 0] - cx, verts[f, i, 1] - cy)
            hmin = min(hmin, h)
            hmax = max(hmax, h)
        if zmax < near or hmin > R:
            continue
        # Near-plane clip (Sutherland-Hodgman), then project.
        m = 0
        if zmin >= near:
            for i in range(n):
                Q[i, :] = P[i, :]
            m = n
        else:
            for i in range(n):
                j = (i + 1) % n
                pin, qin = P[i, 2] >= near, P[j, 2] >= near
                if pin:
                    Q[m, :] = P[i, :]
                    m += 1
                if pin != qin:
                    t = (near - P[i, 2]) / (P[j, 2] - P[i, 2])
                    for a in range(3):
                        Q[m, a] = P[i, a] + t * (P[j, a] - P[i, a])
                    m += 1
            if m < 3:
                continue
        ulo, uhi, vlo, vhi = np.inf, -np.inf, np.inf, -np.inf
        for i in range(m):
            u = fx * Q[i, 0] / Q[i, 2] + px
            v = fy * Q[i, 1] / Q[i, 2] + py
            UV[n_fill, i, 0], UV[n_fill, i, 1] = u, v
            ulo, uhi, vlo, vhi = min(ulo, u), max(uhi, u), min(vlo, v), max(vhi, v)
        if uhi < -0.5 or ulo > W - 0.5 or vhi < -0.5 or vlo > H - 0.5:
            continue
        if max(uhi - ulo, vhi - vlo) < (decal_lod if decal[f] else lod):
            continue
        used[f] = True
        # Plane n . X = k in the camera frame, as n / k.
        nc0 = normal[f, 0] * M[0, 0] + normal[f, 1] * M[1, 0] + normal[f, 2] * M[2, 0]
        nc1 = normal[f, 0] * M[0, 1] + normal[f, 1] * M[1, 1] + normal[f, 2] * M[2, 1]
        nc2 = normal[f, 0] * M[0, 2] + normal[f, 1] * M[1, 2] + normal[f, 2] * M[2, 2]
        k = nc0 * P[0, 0] + nc1 * P[0, 1] + nc2 * P[0, 2]
        PL[n_fill, 0], PL[n_fill, 1], PL[n_fill, 2], PL[n_fill, 3] = nc0 / k, nc1 / k, nc2 / k, hmax
        NV[n_fill] = m
        FA[n_fill] = f
        n_fill += 1
    # Fill band by band of rows (the buffers' rows a band touches stay in cache).
    r_lo, r_hi = H, 0
    XL = np.empty(H)
    XR = np.empty(H)
    Y0 = np.empty(n_fill, dtype=np.int64)
    Y1 = np.empty(n_fill, dtype=np.int64)
    for q in range(n_fill):
        vlo, vhi = np.inf, -np.inf
        for i in range(NV[q]):
            vlo, vhi = min(vlo, UV[q, i, 1]), max(vhi, UV[q, i, 1])
        Y0[q] = max(0, int(np.floor(vlo + 0.5)))
        Y1[q] = min(H - 1, int(np.floor(vhi + 0.5)))
        if Y1[q] >= Y0[q]:
            r_lo, r_hi = min(r_lo, Y0[q]), max(r_hi, Y1[q] + 1)
    for band in range(r_lo, r_hi, _BAND):
        band_end = min(band + _BAND, r_hi) - 1
        for q in range(n_fill):
            if Y0[q] > band_end or Y1[q] < band or Y1[q] < Y0[q]:
                continue
            _fill(q, UV, NV[q], PL[q], face_base + FA[q], decal[FA[q]], max(Y0[q], band),
                  min(Y1[q], band_end), xn, yn, ray, zbuf, fbuf, XL, XR)  # fmt: skip
    return used, r_lo, r_hi


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _fill(q, UV, m, pl, gid, is_decal, ya, yb, xn, yn, ray, zbuf, fbuf, XL, XR):  # pragma: no cover
    """Fill rows ``ya..yb`` of screen polygon ``UV[q, :m]`` with its depth test."""
    W = zbuf.shape[1]
    vlo, vhi = np.inf, -np.inf
    for i in range(m):
        vlo, vhi = min(vlo, UV[q, i, 1]), max(vhi, UV[q, i, 1])
    # x extent per row, edge by edge: of the face within the row's band (y +- 0.5),
    # and every pixel that extent touches: a pixel the face covers in part is drawn
    # (as OpenCV fills polygons), so that a thin pole or rail is never lost.
    thin = 0.5
    XL[ya : yb + 1] = np.inf
    XR[ya : yb + 1] = -np.inf
    for i in range(m):
        j = (i + 1) % m
        ua, va, ub, vb = UV[q, i, 0], UV[q, i, 1], UV[q, j, 0], UV[q, j, 1]
        emin, emax = min(va, vb), max(va, vb)
        y_a = max(ya, int(np.floor(emin + 0.5 - thin)) - 1)
        y_b = min(yb, int(np.floor(emax + 0.5 + thin)) + 1)
        for y in range(y_a, y_b + 1):
            lo = max(min(max(y - thin, vlo), vhi), emin)
            hi = min(min(max(y + thin, vlo), vhi), emax)
            if lo > hi:
                continue
            if va == vb:
                xl, xr = min(ua, ub), max(ua, ub)
            else:
                sl = (ub - ua) / (vb - va)
                x_lo, x_hi = ua + (lo - va) * sl, ua + (hi - va) * sl
                xl, xr = min(x_lo, x_hi), max(x_lo, x_hi)
            XL[y] = min(XL[y], xl)
            XR[y] = max(XR[y], xr)
    a0f, hf = np.float32(pl[0]), np.float32(pl[3])
    tie = np.float32(1.0 + _TIE) if is_decal else np.float32(1.0)
    r00, r01 = np.float32(ray[0, 0]), np.float32(ray[0, 1])
    for y in range(ya, yb + 1):
        if XL[y] > XR[y]:
            continue
        x0 = max(0, int(np.floor(XL[y] + 0.5)))
        x1 = min(W - 1, int(np.floor(XR[y] + 0.5)))
        b = np.float32(pl[1] * yn[y] + pl[2])
        rx0 = np.float32(ray[1, 0] * yn[y] + ray[2, 0])
        ry0 = np.float32(ray[1, 1] * yn[y] + ray[2, 1])
        _span(zbuf[y], fbuf[y], xn, x0, x1, a0f, b, rx0, ry0, r00, r01, hf, tie, np.int32(gid))


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _span(zrow, frow, xn, x0, x1, a0f, b, rx0, ry0, r00, r01, hf, tie, gid):  # pragma: no cover
    """Depth-test pixels ``x0..x1`` of one row: the face wins where
    ``d = min(hd / den, hmax) < cur`` (``hd``: horizontal distance per unit of camera
    depth along the pixel's ray; ``den``: the plane's inverse camera depth), or,
    a decal (``tie > 1``), where it is within the tie of its base face. Branch-free
    with unsigned indices, so that the loop vectorises."""
    for xs in range(x0, x1 + 1):
        x = np.uint64(xs)
        den = max(a0f * xn[x] + b, np.float32(1e-9))
        rx = rx0 + r00 * xn[x]
        ry = ry0 + r01 * xn[x]
        h = np.sqrt(rx * rx + ry * ry)
        cur = zrow[x]
        w = (h < cur * den * tie) | (hf < cur)
        zrow[x] = min(h / den, hf) if w else cur
        frow[x] = gid if w else frow[x]


@njit(cache=True, error_model="numpy")
def face_table(used, colour, centroid, material, haze, cx, cy, R, base, k, remap, out_colour, out_mat, out_table):  # pragma: no cover  # fmt: skip
    """Colour (uint8, faded into the sRGB ``haze`` over the last 40 % of the range
    ``R``; no fading when ``haze`` is NaN), material and face-map entry of the faces
    drawn (``used``) of one mesh, at ``base + f`` of the ``out_*`` tables. The map
    entry is ``k, k + 1, ...`` in order when ``remap``, else the global index.
    Returns the next ``k``."""
    fade = not np.isnan(haze[0])
    for f in range(used.shape[0]):
        if not used[f]:
            continue
        g = base + f
        s = np.float32(0.0)
        if fade:
            d = np.hypot(centroid[f, 0] - cx, centroid[f, 1] - cy)
            t = np.float32(min(max((d - 0.6 * R) / (0.4 * R), 0.0), 1.0))
            s = t * t * (np.float32(3) - np.float32(2) * t)
        for a in range(3):
            v = colour[f, a] + s * (haze[a] - colour[f, a]) if fade else colour[f, a]
            out_colour[g, a] = np.uint8(min(max(v, np.float32(0)), np.float32(255)))
        out_mat[g] = material[f]
        out_table[g] = k if remap else g
        k += 1
    return k


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def shade(fbuf, r0, r1, colour, material_of, remap, rgb, material, road):  # pragma: no cover - compiled
    """Write colour (uint8 (G, 3)) and material (uint8 (G,)) of every pixel's face
    ``fbuf`` (global index, -1 none) in rows ``[r0, r1)``, clear the road mask
    ``road`` (bool (H, W); any other shape for none) there, and turn ``fbuf`` into
    ``remap[fbuf]`` in place."""
    W = fbuf.shape[1]
    clear = road.shape == fbuf.shape
    for y in range(r0, r1):
        frow, crow, mrow = fbuf[y], rgb[y], material[y]
        rrow = road[y if clear else 0]
        for xs in range(W):
            x = np.uint64(xs)  # unsigned: no wrap-around test per index
            g = frow[x]
            if g >= 0:
                u = np.uint64(g)
                crow[x, 0] = colour[u, 0]
                crow[x, 1] = colour[u, 1]
                crow[x, 2] = colour[u, 2]
                mrow[x] = material_of[u]
                frow[x] = remap[u]
                if clear:
                    rrow[x] = False


@njit(cache=True)
def footprints(v, cos, sin, reach, x, y, h, ch, sh):  # pragma: no cover - compiled
    """Footprints of vehicles ``v`` (N, 5): world centre, heading, half length and half
    width (m), with ``cos``/``sin`` of their headings, seen from the ego at world
    ``(x, y)`` with heading ``h`` (``ch``, ``sh``: its cosine and sine). Returns their world corners grown by ``reach`` (m)
    (N, 4, 3; front-left, front-right, rear-right, rear-left; z = 0) and their ego-frame
    boxes (N, 5): centre, heading, half length, half width. The float64 operations
    of the numpy expressions they replace, in their order (no fast-math): the same
    bits."""
    N = v.shape[0]
    corners = np.zeros((N, 4, 3))
    boxes = np.empty((N, 5))
    for i in range(N):
        c, s = cos[i], sin[i]
        hl, hw = v[i, 3] + reach, v[i, 4] + reach
        for j in range(4):
            a = 1.0 if j < 2 else -1.0
            b = 1.0 if j == 1 or j == 2 else -1.0
            corners[i, j, 0] = v[i, 0] + a * hl * c + b * hw * s
            corners[i, j, 1] = v[i, 1] + a * hl * s - b * hw * c
        dx, dy = v[i, 0] - x, v[i, 1] - y
        boxes[i, 0] = ch * dx + sh * dy
        boxes[i, 1] = -sh * dx + ch * dy
        boxes[i, 2] = v[i, 2] - h
        boxes[i, 3] = v[i, 3]
        boxes[i, 4] = v[i, 4]
    return corners, boxes


@njit(cache=True, error_model="numpy")
def contact_shadows(rgb, ground, face_id, gx, gy, boxes, corners, cam, strength, inner, reach):  # pragma: no cover - compiled  # fmt: skip
    """Darken ground pixels around vehicle footprints (ambient occlusion), in place.

    ``gx, gy`` (H, W): ego-frame ground point of each pixel; ``ground`` (H, W) bool:
    the pixel sees flat ground; ``face_id`` (H, W) int32: a face hides the pixel's
    ground where >= 0 (left as it is); ``boxes`` (N, 5): ego-frame centre, heading, half
    length and half width of each footprint; ``corners`` (N, 4, 3): camera-frame
    corners of each footprint grown by ``reach`` (only pixels in their screen box are
    visited); ``cam``: ``(fx, fy, px, py, near)``. A pixel near several vehicles takes
    the strongest occlusion.
    """
    H, W = ground.shape
    fx, fy, px, py, near = cam[0], cam[1], cam[2], cam[3], cam[4]
    N = boxes.shape[0]
    rect = np.full((N, 4), -1, dtype=np.int64)
    y_lo, y_hi, x_lo, x_hi = H, -1, W, -1
    for i in range(N):
        ulo, uhi, vlo, vhi = np.inf, -np.inf, np.inf, -np.inf
        for k in range(4):  # screen box of the footprint clipped to the near plane
            for e in range(2):
                p, q = corners[i, k], corners[i, (k + 1) % 4]
                if e == 0 and p[2] >= near:
                    u, v = fx * p[0] / p[2] + px, fy * p[1] / p[2] + py
                elif e == 1 and (p[2] >= near) != (q[2] >= near):
                    t = (near - p[2]) / (q[2] - p[2])
                    u = fx * (p[0] + t * (q[0] - p[0])) / near + px
                    v = fy * (p[1] + t * (q[1] - p[1])) / near + py
                else:
                    continue
                ulo, uhi, vlo, vhi = min(ulo, u), max(uhi, u), min(vlo, v), max(vhi, v)
        if not (ulo <= uhi) or uhi < 0 or vhi < 0 or ulo > W - 1 or vlo > H - 1:
            continue
        rect[i, 0], rect[i, 2] = max(0, int(np.floor(ulo))), min(W - 1, int(np.ceil(uhi)))
        rect[i, 1], rect[i, 3] = max(0, int(np.floor(vlo))), min(H - 1, int(np.ceil(vhi)))
        y_lo, y_hi = min(y_lo, rect[i, 1]), max(y_hi, rect[i, 3])
        x_lo, x_hi = min(x_lo, rect[i, 0]), max(x_hi, rect[i, 2])
    if y_hi < y_lo:
        return
    gain = np.ones((y_hi - y_lo + 1, x_hi - x_lo + 1), dtype=np.float32)
    for i in range(N):
        if rect[i, 0] < 0:
            continue
        ex, ey, hh, hl, hw = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3], boxes[i, 4]
        cr, sr = np.cos(hh), np.sin(hh)
        for y in range(rect[i, 1], rect[i, 3] + 1):
            for x in range(rect[i, 0], rect[i, 2] + 1):
                if not ground[y, x] or face_id[y, x] >= 0:
                    continue
                dx, dy = gx[y, x] - ex, gy[y, x] - ey
                qx = abs(cr * dx + sr * dy) - hl
                qy = abs(-sr * dx + cr * dy) - hw
                sd = np.hypot(max(qx, 0.0), max(qy, 0.0)) + min(max(qx, qy), 0.0)
                a = min(max((reach - sd) / (reach + inner), 0.0), 1.0)
                if a <= 0.0:
                    continue
                g = (1.0 - strength * a * a * (3 - 2 * a)) ** (1 / GAMMA)
                if g < gain[y - y_lo, x - x_lo]:
                    gain[y - y_lo, x - x_lo] = g
    for y in range(y_lo, y_hi + 1):
        for x in range(x_lo, x_hi + 1):
            g = gain[y - y_lo, x - x_lo]
            if g < 1.0:
                for c in range(3):
                    rgb[y, x, c] = np.uint8(rgb[y, x, c] * g)


@njit(cache=True)
def fade(rgb, alpha, haze):  # pragma: no cover - compiled
    """Fade the rows ``rgb`` (uint8 (h, W, 3)) into the sRGB ``haze`` (float32 (3,)) by
    ``alpha`` (float32 (h, W, 1)), in place: ``v + alpha (haze - v)`` in float32 and
    truncated, each operation rounded as numpy's float32 array operations do."""
    h, w = rgb.shape[0], rgb.shape[1]
    for y in range(h):
        for x in range(w):
            a = alpha[y, x, 0]
            for c in range(3):
                v = np.float32(rgb[y, x, c])
                rgb[y, x, c] = np.uint8(v + a * (haze[c] - v))
