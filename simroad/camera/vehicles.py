"""Vehicles as meshes: body, cabin with glass, wheels, lights and plates, in real paints.

A vehicle is seven convex solids (:class:`~simroad.camera.mesh.Mesh`): the body (a
box a little narrower than highway-env's ``LENGTH x WIDTH`` footprint, lifted by the
ground clearance), the cabin (a frustum set back on the body, with slanted windscreen
and rear window) and four wheels (octagonal tyres, each the part beside the body and
the part under it). Decals follow their base face: side windows, windscreen and rear
window (glass), tail lights, head lights, grille and licence plates.

Body colours come from :data:`PAINTS`, the global shares of car colours in
Axalta's 2022 Global Automotive Color Popularity Report, with linear albedos per
colour (docs/vehicles.md gives the sources).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from simroad.camera.codes import VEHICLE
from simroad.camera.lighting import NOMINAL_EXPOSURE
from simroad.camera.materials import ALBEDO
from simroad.camera.mesh import MAX_VERTICES, Mesh
from simroad.core.radiometry import GAMMA
from simroad.core.validation import normalize_rng

__all__ = [
    "PAINTS",
    "VEHICLE_HEIGHT_M",
    "Paint",
    "VehicleBox",
    "box_mesh",
    "draw_paint",
    "paint_rgb",
    "vehicle_mesh",
    "vehicles_mesh",
]

#: Height of a vehicle box, m.
VEHICLE_HEIGHT_M = 1.5


@dataclass(frozen=True)
class VehicleBox:
    """A vehicle to draw: centre ``(x, y)`` in m, heading in rad, size in m, RGB.

    ``rgb`` (sRGB) colours it in the bird's-eye view; ``paint`` is the linear albedo
    of its body in the camera (decoded from ``rgb`` when ``None``; see
    :func:`simroad.camera.vehicles.draw_paint`).
    """

    x: float
    y: float
    heading: float
    length: float
    width: float
    rgb: tuple[int, int, int]
    height: float = VEHICLE_HEIGHT_M
    paint: tuple[float, float, float] | None = None

    def corners(self) -> np.ndarray:
        """Ground corners (4, 2): front-left, front-right, rear-right, rear-left."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        fwd, right = np.array([c, s]), np.array([-s, c])
        hl, hw = self.length / 2, self.width / 2
        ctr = np.array([self.x, self.y])
        return np.array(
            [
                ctr + hl * fwd - hw * right,
                ctr + hl * fwd + hw * right,
                ctr - hl * fwd + hw * right,
                ctr - hl * fwd - hw * right,
            ]
        )


@dataclass(frozen=True)
class Paint:
    """One car colour: its share of cars and its linear RGB albedo range."""

    share: float
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


#: Car colours by global share (Axalta 2022: white 34 %, black 21 %, grey 19 %,
#: silver 8 %, blue 8 %, red 5 %, green 1 %, others 4 %) with linear albedos
#: (docs/vehicles.md: Levinson et al. 2011 for white/silver/black shells).
PAINTS: dict[str, Paint] = {
    "white": Paint(0.34, (0.60, 0.61, 0.60), (0.80, 0.80, 0.78)),
    "black": Paint(0.21, (0.030, 0.030, 0.032), (0.050, 0.050, 0.055)),
    "grey": Paint(0.19, (0.08, 0.08, 0.085), (0.22, 0.22, 0.23)),
    "silver": Paint(0.08, (0.28, 0.29, 0.30), (0.45, 0.46, 0.47)),
    "blue": Paint(0.08, (0.02, 0.04, 0.12), (0.06, 0.11, 0.32)),
    "red": Paint(0.05, (0.22, 0.02, 0.02), (0.42, 0.05, 0.04)),
    "green": Paint(0.01, (0.03, 0.08, 0.04), (0.08, 0.18, 0.08)),
    "other": Paint(0.04, (0.15, 0.11, 0.07), (0.45, 0.37, 0.25)),  # beige, brown, gold, orange
}
_NAMES = tuple(PAINTS)
_SHARES = np.array([PAINTS[n].share for n in _NAMES])

_GLASS = np.array(ALBEDO["glass"].hi, dtype=np.float32) * np.float32(0.8)
_TYRE = np.array(ALBEDO["tyre"].lo, dtype=np.float32)
_TAIL = np.array([0.75, 0.03, 0.02], dtype=np.float32)  # red lens, lit a little
_HEAD = np.array([0.55, 0.56, 0.58], dtype=np.float32)  # clear lens over a reflector
_PLATE = np.array([0.62, 0.62, 0.58], dtype=np.float32)
_GRILLE = np.array([0.025, 0.025, 0.025], dtype=np.float32)
_PAINT = np.array([-1.0, -1.0, -1.0], dtype=np.float32)  # marker: the body colour

CLEARANCE_FRAC = 0.17  # body bottom, fraction of the height
BELT_FRAC = 0.62  # body top (the cabin's base), fraction of the height


def draw_paint(rng: np.random.Generator | int) -> tuple[str, np.ndarray]:
    """One car's colour: its name and linear RGB albedo (float32 (3,))."""
    rng = normalize_rng(rng)
    k = int(rng.choice(len(_NAMES), p=_SHARES / _SHARES.sum()))
    p = PAINTS[_NAMES[k]]
    t = rng.random()
    lo, hi = np.asarray(p.lo), np.asarray(p.hi)
    return _NAMES[k], (lo + t * (hi - lo)).astype(np.float32)


def paint_rgb(albedo: np.ndarray) -> tuple[int, int, int]:
    """sRGB colour (0..255) of a horizontal surface of linear ``albedo`` in clear weather
    (the bird's-eye view's colour of a car)."""

    lin = np.clip(NOMINAL_EXPOSURE * np.asarray(albedo, dtype=float), 0.0, 1.0)
    r, g, b = (int(round(255.0 * x ** (1.0 / GAMMA))) for x in lin)
    return r, g, b


# ------------------------------------------------------------------ geometry
class _Builder:
    def __init__(self) -> None:
        self.faces: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.albedo: list[np.ndarray] = []
        self.solid: list[int] = []
        self.n_solids = 0

    def add(self, poly: np.ndarray, normal: np.ndarray, albedo: np.ndarray) -> None:
        self.faces.append(np.asarray(poly, dtype=float))
        self.normals.append(np.asarray(normal, dtype=float) / np.linalg.norm(normal))
        self.albedo.append(albedo)
        self.solid.append(self.n_solids)

    def convex(self, polys: list[np.ndarray], albedo: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Add a closed convex solid; returns (face, outward normal) of each face."""
        centre = np.vstack(polys).mean(axis=0)
        out = []
        for p in polys:
            n = np.cross(p[1] - p[0], p[2] - p[0])
            if np.dot(n, p.mean(axis=0) - centre) < 0:
                n = -n
            self.add(p, n, albedo)
            out.append((p, n))
        return out

    def end_solid(self) -> None:
        self.n_solids += 1


def _hexahedron(x0, x1, w0, z0, u0, u1, w1, z1) -> list[np.ndarray]:
    """Faces of a frustum between the rectangles x in [x0, x1], |y| <= w0 at z0 and
    x in [u0, u1], |y| <= w1 at z1: bottom, top, rear, front, left, right."""
    b = np.array([[x0, -w0, z0], [x1, -w0, z0], [x1, w0, z0], [x0, w0, z0]])
    t = np.array([[u0, -w1, z1], [u1, -w1, z1], [u1, w1, z1], [u0, w1, z1]])
    return [
        b,
        t,
        np.array([b[0], b[3], t[3], t[0]]),
        np.array([b[1], b[2], t[2], t[1]]),
        np.array([b[0], b[1], t[1], t[0]]),
        np.array([b[3], b[2], t[2], t[3]]),
    ]


def _inset(quad: np.ndarray, s0: float, s1: float, t0: float, t1: float) -> np.ndarray:
    """Sub-quad of a planar quad (b0, b1, t1, t0) by bilinear parameters."""
    b0, b1, q1, q0 = quad

    def at(s: float, t: float) -> np.ndarray:
        return (1 - t) * (b0 + s * (b1 - b0)) + t * (q0 + s * (q1 - q0))

    return np.array([at(s0, t0), at(s1, t0), at(s1, t1), at(s0, t1)])


def _wheel(b: _Builder, xc: float, r: float, side: float, y_in: float, y_body: float, y_out: float, zb: float):
    ang = (np.arange(8) + 0.5) * (2 * math.pi / 8)
    prof = np.column_stack([xc + r * np.cos(ang), r + r * np.sin(ang)])  # (x, z) octagon

    def prism(profile: np.ndarray, ya: float, yb: float) -> None:
        k = len(profile)
        a = np.column_stack([profile[:, 0], np.full(k, side * ya), profile[:, 1]])
        c = np.column_stack([profile[:, 0], np.full(k, side * yb), profile[:, 1]])
        polys = [a, c[::-1]] + [np.array([a[i], a[(i + 1) % k], c[(i + 1) % k], c[i]]) for i in range(k)]
        b.convex(polys, _TYRE)
        b.end_solid()

    prism(prof, y_body, y_out)  # beside the body
    # Under the body: the octagon cut at the body's bottom (convex).
    low = []
    for i in range(8):
        p, q = prof[i], prof[(i + 1) % 8]
        if p[1] <= zb:
            low.append(p)
        if (p[1] - zb) * (q[1] - zb) < 0:
            low.append(p + (zb - p[1]) / (q[1] - p[1]) * (q - p))
    prism(np.array(low), y_in, y_body)


@lru_cache(maxsize=16)
def _template(
    length: float, width: float, height: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Vehicle faces in the vehicle frame (x forward, y right, z up), paint marked."""
    b = _Builder()
    L, W, H = length, width, height
    zb, zt = CLEARANCE_FRAC * H, BELT_FRAC * H
    hl, hw = 0.49 * L, 0.45 * W
    body = b.convex(_hexahedron(-hl, hl, hw, zb, -hl, hl, hw, zt), _PAINT)
    rear, front = body[2][0], body[3][0]
    # rear face corners: (x=-hl): b0=(-hl,-hw,zb), b3=(-hl,hw,zb), t3, t0
    for y0, y1 in ((-0.44 * W, -0.30 * W), (0.30 * W, 0.44 * W)):
        _decal(b, rear, body[2][1], y0, y1, zt - 0.2, zt - 0.05, _TAIL)
        _decal(b, front, body[3][1], y0, y1, zt - 0.2, zt - 0.07, _HEAD)
    _decal(b, front, body[3][1], -0.24 * W, 0.24 * W, zb + 0.12, zt - 0.1, _GRILLE)
    _decal(b, rear, body[2][1], -0.26, 0.26, zb + 0.12, zb + 0.24, _PLATE)
    _decal(b, front, body[3][1], -0.26, 0.26, zb + 0.03, zb + 0.14, _PLATE)
    b.end_solid()
    cab = b.convex(_hexahedron(-0.40 * L, 0.17 * L, 0.43 * W, zt, -0.31 * L, -0.03 * L, 0.36 * W, H), _PAINT)
    _, _, (rq, rn), (fq, fn), (lq, ln), (sq, sn) = cab
    b.add(_inset(rq, 0.08, 0.92, 0.12, 0.88), rn, _GLASS)  # rear window
    b.add(_inset(fq, 0.06, 0.94, 0.08, 0.9), fn, _GLASS)  # windscreen
    for q, n in ((lq, ln), (sq, sn)):
        b.add(_inset(q, 0.05, 0.47, 0.12, 0.88), n, _GLASS)
        b.add(_inset(q, 0.53, 0.9, 0.12, 0.88), n, _GLASS)
    b.end_solid()
    r = 0.21 * H
    for xc in (-0.31 * L, 0.31 * L):
        for side in (-1.0, 1.0):
            _wheel(b, xc, r, side, 0.27 * W, hw, 0.5 * W, zb)
    F = len(b.faces)
    verts = np.zeros((F, MAX_VERTICES, 3))
    counts = np.zeros(F, dtype=np.int32)
    for k, p in enumerate(b.faces):
        verts[k, : len(p)] = p
        verts[k, len(p) :] = p[-1]
        counts[k] = len(p)
    albedo = np.array(b.albedo, dtype=np.float32)
    return verts, counts, albedo, np.array(b.normals), np.array(b.solid, dtype=np.int64), b.n_solids


def box_mesh(
    x: float,
    y: float,
    heading: float,
    length: float,
    width: float,
    z0: float,
    z1: float,
    *,
    albedo: tuple[float, float, float],
    material: int,
) -> Mesh:
    """One box (a convex solid of six faces): centre ``(x, y)`` (m), ``heading`` (rad),
    ``length`` along it and ``width`` across (m), from height ``z0`` to ``z1`` (m)."""
    b = _Builder()
    b.convex(_hexahedron(-length / 2, length / 2, width / 2, z0, -length / 2, length / 2, width / 2, z1), _PAINT)
    verts = np.array([np.vstack([f, np.repeat(f[-1:], MAX_VERTICES - len(f), axis=0)]) for f in b.faces])
    c, s = math.cos(heading), math.sin(heading)
    wv = verts.copy()
    wv[..., 0] = x + c * verts[..., 0] - s * verts[..., 1]
    wv[..., 1] = y + s * verts[..., 0] + c * verts[..., 1]
    n = np.array(b.normals)
    wn = np.column_stack([c * n[:, 0] - s * n[:, 1], s * n[:, 0] + c * n[:, 1], n[:, 2]])
    return Mesh(
        wv,
        np.full(6, 4, dtype=np.int32),
        np.tile(np.asarray(albedo, dtype=np.float32), (6, 1)),
        np.full(6, material, dtype=np.uint8),
        wn,
        np.zeros(6, dtype=np.int64),
    )


def _decal(b: _Builder, face: np.ndarray, normal: np.ndarray, y0: float, y1: float, z0: float, z1: float, alb) -> None:
    """A rectangle on a vertical face of constant x (rear or front of the body)."""
    x = float(face[0, 0]) + 0.0
    b.add(np.array([[x, y0, z0], [x, y1, z0], [x, y1, z1], [x, y0, z1]]), normal, alb)


def vehicles_mesh(boxes: Sequence, paints: np.ndarray | None = None) -> Mesh:
    """One mesh of all ``boxes`` (:class:`VehicleBox`).

    Parameters
    ----------
    boxes : sequence of VehicleBox
    paints : ndarray float32 (N, 3), optional
        Linear body albedo of each box; from ``box.paint`` (or its ``rgb``) when omitted.
    """
    if not len(boxes):
        return Mesh.empty()
    groups: dict[tuple[float, float, float], list[int]] = {}
    for i, v in enumerate(boxes):
        groups.setdefault((float(v.length), float(v.width), float(v.height)), []).append(i)
    if paints is None:
        paints = np.array([_box_paint(v) for v in boxes], dtype=np.float32)
    parts = []
    for dims, idx in groups.items():
        verts, counts, albedo, normal, _, _ = _template(*dims)
        pose = np.array([[boxes[i].x, boxes[i].y, boxes[i].heading] for i in idx])
        N, F = len(idx), len(counts)
        wv = np.empty((N * F, MAX_VERTICES, 3))
        wn = np.empty((N * F, 3))
        alb = np.empty((N * F, 3), dtype=np.float32)
        _place(verts, normal, albedo, pose, np.cos(pose[:, 2]), np.sin(pose[:, 2]), paints[idx], wv, wn, alb)
        n_counts, n_material, n_solid = _fixed_faces(dims, N)
        parts.append(Mesh(wv, n_counts, alb, n_material, wn, n_solid))
    if len(parts) == 1:
        return parts[0]
    return Mesh.concat(parts)


@lru_cache(maxsize=64)
def _fixed_faces(dims: tuple[float, float, float], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Counts, material and solid ids of ``n`` vehicles of size ``dims`` (read-only:
    they do not move with the vehicles, so frames share them)."""
    _, counts, _, _, solid, n_solids = _template(*dims)
    out = (
        np.tile(counts, n),
        np.full(n * len(counts), VEHICLE, dtype=np.uint8),
        (solid[None, :] + n_solids * np.arange(n)[:, None]).reshape(-1),
    )
    for a in out:
        a.flags.writeable = False
    return out


@njit(cache=True, nogil=True)
def _place(verts, normal, albedo, pose, cos, sin, paints, wv, wn, alb):  # pragma: no cover - compiled
    """The template's faces (``verts`` (F, V, 3), ``normal`` (F, 3), ``albedo`` (F, 3),
    paint marked < 0) moved to each pose ``(x, y, heading)`` (N, 3) with its ``cos``
    and ``sin``, painted ``paints`` (N, 3): into ``wv`` (N F, V, 3), ``wn`` (N F, 3) and
    ``alb`` (N F, 3). The same float64 operations, in the same order, as a numpy
    rotation (no fast-math): the result is that of numpy to the bit."""
    F, V = verts.shape[0], verts.shape[1]
    for i in range(pose.shape[0]):
        x, y, c, s = pose[i, 0], pose[i, 1], cos[i], sin[i]
        for f in range(F):
            g = i * F + f
            for k in range(V):
                vx, vy = verts[f, k, 0], verts[f, k, 1]
                wv[g, k, 0] = x + c * vx - s * vy
                wv[g, k, 1] = y + s * vx + c * vy
                wv[g, k, 2] = verts[f, k, 2]
            nx, ny = normal[f, 0], normal[f, 1]
            wn[g, 0] = c * nx - s * ny
            wn[g, 1] = s * nx + c * ny
            wn[g, 2] = normal[f, 2]
            paint = albedo[f, 0] < 0
            for a in range(3):
                alb[g, a] = paints[i, a] if paint else albedo[f, a]


def vehicle_mesh(box) -> Mesh:
    """The mesh of one vehicle (:class:`VehicleBox`)."""
    return vehicles_mesh([box])


def _box_paint(box) -> np.ndarray:
    paint = getattr(box, "paint", None)
    if paint is not None:
        return np.asarray(paint, dtype=np.float32)

    return (np.asarray(box.rgb, dtype=np.float32) / 255.0) ** GAMMA
