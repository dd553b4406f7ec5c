"""Scenery of the world: trees, poles, signs, buildings, walls, guard rails, overpasses.

The world is cut into square cells (``cell_m``). The objects of cell (i, j) are
drawn from a generator seeded by ``(seed, i, j)`` only, so a cell's contents never
depend on which cells were visited before; each object belongs to the cell of its
anchor point. Two kinds of placement:

* **along the road** -- the road's outer edge lines (:mod:`._scenery_road`) are
  cut into stretches of ``STRETCH_M``; each stretch of each edge decides from its
  own generator (seeded by ``(seed, chain, side, stretch)``, so a run continues
  across cells) whether it carries a guard rail, a wall, a line of street lights,
  a row of town facades or street trees, laid out at fixed arc lengths along the
  edge (rails and walls in 12 m slots of as few straight pieces as follow the
  curve, facades abutting along the road's normals);
* **scattered** -- trees (partly in clumps), houses and signs at Poisson-drawn
  points at a distance from the road typical of their kind; overpasses cross the
  road at a random edge sample.

Nothing stands on a lane or its shoulder (nor, in a town, on the sidewalk except
street trees and lamp posts at its kerb side): every solid reaching below :data:`HIGH_M`
(3 m) is accepted only if all its ground corners are at least ``shoulder_m`` (plus
the sidewalk in towns) from every lane surface. Only overpass decks, street-light
arms and the crowns of street trees, all higher, reach over it.

No two objects intersect (tree crowns excepted, which overlap as canopies do): the
painter's visibility order is exact only for disjoint convex solids. Each cell's
draws are its *candidates*; a candidate gives way to any intersecting candidate of
higher priority (:data:`RANK`, then cell and order of drawing) within the cells
its reach allows (:mod:`._scenery_conflicts`), so a cell stays a pure function of
the seed and its index. No object reaches more than ``_MARGIN_M`` beyond its cell.

Densities per profile are :data:`PROFILES` (per km of road edge, per stretch);
``density`` scales them (0 = nothing, 1 = the profile's, up to 5).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from simroad.camera import _scenery_kinds as kinds
from simroad.camera._scenery_conflicts import Candidates, kept_objects
from simroad.camera._scenery_road import RoadIndex
from simroad.camera._scenery_solids import SolidBuilder, outline, rect
from simroad.camera.materials import draw_albedo
from simroad.camera.mesh import Mesh
from simroad.core.validation import check_choice, check_in_range

__all__ = ["HIGH_M", "PROFILES", "RANK", "STRETCH_M", "Scenery", "SceneryProfile"]

#: Length of the road-edge stretches that decide rails, walls, lights, facades, m.
STRETCH_M = 120.0
_MARGIN_M = 40.0  # largest reach of an object beyond its anchor's cell, m (farther: dropped)
_SLOT_M = 12.0  # guard rails and walls are laid out in slots of this length, m
#: Placement priority of each kind (lower first): along-road objects, then scattered.
RANK = {
    "overpass": 0,
    "facade": 1,
    "wall": 2,
    "rail": 3,
    "light": 4,
    "street_tree": 5,
    "house": 6,
    "sign": 7,
    "tree": 8,
}
#: Solids whose lowest point is at least this high (m) may reach over the road and
#: its shoulder (overpass decks, light arms, street-tree crowns); none lower does.
HIGH_M = 3.0
_RING = np.column_stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)])


@dataclass(frozen=True)
class SceneryProfile:
    """Densities of one kind of place (per km of one road edge, or the probability
    that a stretch of one road edge carries the feature)."""

    trees_per_km: float
    clump_p: float  # probability a scattered tree comes with 2-5 neighbours
    conifer_p: float
    houses_per_km: float
    signs_per_km: float
    lights_p: float
    light_arm_p: float
    rail_p: float
    wall_p: float
    overpass_per_km: float
    facade_p: float = 0.0
    street_trees_p: float = 0.0


PROFILES: dict[str, SceneryProfile] = {
    "rural": SceneryProfile(
        trees_per_km=45.0, clump_p=0.5, conifer_p=0.3, houses_per_km=3.0, signs_per_km=6.0,
        lights_p=0.3, light_arm_p=0.6, rail_p=0.3, wall_p=0.06, overpass_per_km=0.4,
    ),
    "urban": SceneryProfile(
        trees_per_km=4.0, clump_p=0.0, conifer_p=0.1, houses_per_km=0.0, signs_per_km=14.0,
        lights_p=0.9, light_arm_p=0.9, rail_p=0.0, wall_p=0.0, overpass_per_km=0.1,
        facade_p=0.9, street_trees_p=0.6,
    ),
}  # fmt: skip


class Scenery:
    """The objects standing in one world, built lazily per cell and cached.

    Parameters
    ----------
    shapes : list of LaneShape or None
        ``WorldRaster.shapes`` (the lanes); ``None``: a straight road along x.
    seed : int
        The episode's scenery seed (every draw derives from it).
    profile : {"rural", "urban"}
        Kind of place (:data:`PROFILES`).
    density : float
        Scale of every density in [0, 5].
    shoulder_m : float
        Shoulder width beside the lanes, m (nothing stands on it).
    sidewalk_m : float
        Sidewalk width beyond the shoulder (towns), m: facades stand behind it,
        street trees and lights at its kerb side.
    cell_m : float
        Side of the placement cells, m.
    max_cells : int
        Size of the per-cell mesh cache (LRU).
    """

    def __init__(
        self,
        shapes,
        seed: int,
        *,
        profile: str = "rural",
        density: float = 1.0,
        shoulder_m: float = 1.0,
        sidewalk_m: float = 0.0,
        cell_m: float = 40.0,
        max_cells: int = 512,
    ) -> None:
        check_choice("profile", profile, tuple(PROFILES))
        self.profile = PROFILES[profile]
        self.profile_name = profile
        self.density = check_in_range("density", density, 0.0, 5.0)
        self.shoulder_m = check_in_range("shoulder_m", shoulder_m, 0.0, 20.0, unit="m")
        self.sidewalk_m = check_in_range("sidewalk_m", sidewalk_m, 0.0, 20.0, unit="m")
        self.cell_m = check_in_range("cell_m", cell_m, 10.0, 500.0, unit="m")
        self.seed = int(seed)
        self.max_cells = int(max_cells)
        self.road = RoadIndex(shapes, self.cell_m)
        self._hood = math.ceil(2 * _MARGIN_M / self.cell_m)  # cells whose objects may meet
        self._cells: OrderedDict[tuple[int, int], tuple[Mesh, np.ndarray, np.ndarray]] = OrderedDict()
        self._cands: OrderedDict[tuple[int, int], Candidates] = OrderedDict()
        self._last: tuple[tuple[int, int, int, int] | None, Mesh] = (None, Mesh.empty())

    # ------------------------------------------------------------------ API
    def _keys(self, xmin: float, ymin: float, xmax: float, ymax: float) -> list[tuple[int, int]]:
        c, m = self.cell_m, _MARGIN_M
        i0, j0 = math.floor((xmin - m) / c), math.floor((ymin - m) / c)
        i1, j1 = math.floor((xmax + m) / c), math.floor((ymax + m) / c)
        return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]

    def meshes(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Mesh:
        """Every solid that may reach into the world box (metres), as one mesh."""
        keys = self._keys(xmin, ymin, xmax, ymax)
        key = (*keys[0], *keys[-1])
        if self._last[0] != key:
            self._last = (key, Mesh.concat([self.cell(*k) for k in keys]))
        return self._last[1]

    def solid_objects(self, xmin: float, ymin: float, xmax: float, ymax: float) -> tuple[np.ndarray, np.ndarray]:
        """For each solid id of ``meshes(box)``: its object's key (int64; the pieces
        of one guard rail or wall run share one) and whether it is a tree crown."""
        keys, crowns = [], []
        for k in self._keys(xmin, ymin, xmax, ymax):
            mesh = self.cell(*k)
            if len(mesh):
                _, key, crown = self._cells[k]
                n = int(mesh.solid.max()) + 1
                keys.append(key[:n])
                crowns.append(crown[:n])
        if not keys:
            return np.zeros(0, np.int64), np.zeros(0, bool)
        return np.concatenate(keys), np.concatenate(crowns)

    def cell(self, i: int, j: int) -> Mesh:
        """The solids anchored in world cell (i, j) (cached; a pure function of the
        seed and the cell index)."""
        key = (i, j)
        hit = self._cells.get(key)
        if hit is not None:
            self._cells.move_to_end(key)
            return hit[0]
        own = self._candidates(i, j)
        r = self._hood
        hood = [self._candidates(i + a, j + b) for a in range(-r, r + 1) for b in range(-r, r + 1)]
        keep = kept_objects(own, hood)
        out = own.mesh.select(keep[own.mesh.solid])
        self._cells[key] = (out, own.key, own.crown)
        if len(self._cells) > self.max_cells:
            self._cells.popitem(last=False)
        return out

    def _candidates(self, i: int, j: int) -> Candidates:
        """Every object the cell's draws propose, before giving way to others."""
        key = (i, j)
        hit = self._cands.get(key)
        if hit is not None:
            self._cands.move_to_end(key)
            return hit
        b = SolidBuilder()
        if self.density > 0.0:
            rng = np.random.default_rng([self.seed, i + 2**31, j + 2**31])
            self._along_road(b, i, j)
            self._scatter(b, rng, i, j)
            self._overpass(b, rng, i, j)
            c = self.cell_m
            b.keep_within(np.array([i * c, j * c]) - _MARGIN_M, np.array([i * c + c, j * c + c]) + _MARGIN_M)
        out = Candidates.build(b, ((i + 2**15) % 2**16) << 16 | ((j + 2**15) % 2**16))
        self._cands[key] = out
        if len(self._cands) > 4 * self.max_cells:
            self._cands.popitem(last=False)
        return out

    # ------------------------------------------------------------ placement
    def _rate(self, per_km: float) -> float:
        return per_km * self.density

    def _p(self, p: float) -> float:
        """Stretch probability scaled by the density (1 - (1 - p)**density)."""
        return 1.0 - (1.0 - min(p, 1.0)) ** self.density

    def _clear(self, pts: np.ndarray, extra: float = 0.0) -> bool:
        """All ground points (N, 2) at least shoulder + ``extra`` from every lane."""
        return bool((self.road.distance(pts, reach=self.shoulder_m + extra + 5.0) >= self.shoulder_m + extra).all())

    def _rng(self, chain: int, side: int, at: float, what: int) -> np.random.Generator:
        """The generator of the object ``what`` at arc length ``at`` along a chain's edge."""
        return np.random.default_rng([self.seed, 1 + what, chain, side + 1, int(round(at * 8.0)) + 2**40])

    def _along_road(self, b: SolidBuilder, i: int, j: int) -> None:
        """Rails, walls, lights, facades and street trees along the cell's edge
        samples: each sample owns the slots starting in ``[sg, sg + step)``."""
        e = self.road.edge_samples(i, j, self.shoulder_m + self.sidewalk_m + 0.5)
        for row in e:
            lane, side, s, chain, sg = int(row[0]), int(row[1]), float(row[2]), int(row[8]), float(row[9])
            if s >= self.road.lane_length(lane) - 1e-6:
                continue  # a lane's last sample: the next lane of the chain starts here
            end = sg + self.road.step(lane)
            for k in sorted({math.floor(sg / STRETCH_M), math.floor((end - 1e-9) / STRETCH_M)}):
                lo, hi = max(sg, k * STRETCH_M), min(end, (k + 1) * STRETCH_M, self.road.chain_end(chain))
                if hi > lo:
                    self._stretch(b, chain, side, k, lo, hi)

    def _stretch(self, b: SolidBuilder, chain: int, side: int, k: int, lo: float, hi: float) -> None:
        """The along-road objects of stretch ``k`` whose slots start in ``[lo, hi)``."""
        p, sh, sw = self.profile, self.shoulder_m, self.sidewalk_m
        st = np.random.default_rng([self.seed, 1, chain, side + 1, k + 2**40])
        u = st.random(12)
        s0 = k * STRETCH_M

        def starts(first: float, pitch: float) -> list[float]:
            m = max(math.ceil((lo - s0 - first) / pitch - 1e-9), 0)
            out = []
            while s0 + first + pitch * m < hi:
                out.append(s0 + first + pitch * m)
                m += 1
            return out

        group = (chain * 4 + side + 1) * 8
        if u[0] < self._p(p.rail_p) and sw == 0.0:
            steel = draw_albedo("galvanised_steel", st)
            for t in starts(0.0, _SLOT_M):
                self._rail(b, chain, side, t, steel, group + 1)
        if u[1] < self._p(p.wall_p):
            brick = draw_albedo(("concrete", "brick")[int(u[3] < 0.3)], st)
            off, height = sh + sw + 2.0 + 2.0 * u[2], 2.0 + 2.0 * u[4]
            for t in starts(0.0, _SLOT_M):
                pts, nrm, _ = self._run(chain, side, t, off)
                if self._clear(pts, sw + 1.5):
                    b.begin(RANK["wall"], group + 2)
                    for q in range(len(pts) - 1):
                        fp = np.array([pts[q], pts[q + 1], pts[q + 1] + 0.3 * nrm[q + 1], pts[q] + 0.3 * nrm[q]])
                        kinds.wall(b, brick, fp, height)
        if u[5] < self._p(p.lights_p):
            spacing, steel = 28.0 + 14.0 * u[6], draw_albedo("galvanised_steel", st)
            for t in starts(spacing / 2, spacing):
                lrng = self._rng(chain, side, t, 2)
                off = sh + (0.45 if sw > 0 else 0.8 + 0.8 * lrng.random())
                at, nrm = self.road.chain_points(chain, side, [t], off)
                if self._clear(at, 0.3):
                    b.begin(RANK["light"])
                    kinds.street_light(b, lrng, at[0], -nrm[0], steel, arm=lrng.random() < p.light_arm_p)
        if sw >= 2.5 and u[7] < self._p(p.street_trees_p):
            spacing = 9.0 + 6.0 * u[8]
            for t in starts(spacing * 0.3, spacing):
                trng = self._rng(chain, side, t, 6)
                at, _ = self.road.chain_points(chain, side, [t], sh + 0.7)
                r = min(kinds.tree_radius("round", trng.random() * 0.4), sw - 0.6)
                if self._clear(at, 0.5):
                    b.begin(RANK["street_tree"])
                    kinds.tree(b, trng, at[0], "round", r, crown_bottom_m=HIGH_M)
        if sw > 0 and u[9] < self._p(p.facade_p):
            width = STRETCH_M / (6 + int(u[10] * 7))  # 9-20 m frontages, no gaps
            for t in starts(0.0, width):
                self._facade(b, chain, side, t, min(t + width, self.road.chain_end(chain)))

    def _run(self, chain: int, side: int, t: float, off: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The slot from ``t`` as a polyline ``off`` m beyond the edge (see
        :meth:`RoadIndex.polyline`)."""
        return self.road.polyline(chain, side, t, min(t + _SLOT_M, self.road.chain_end(chain)), off)

    def _rail(self, b: SolidBuilder, chain: int, side: int, t: float, steel, group: int) -> None:
        """One slot of a guard rail: the beam and posts every 6 m."""
        pts, nrm, ts = self._run(chain, side, t, self.shoulder_m + 0.25)
        if not self._clear(pts, 0.2):
            return
        at = [s for s in (t, t + 6.0) if s < ts[-1] - 1.0]
        pp, pn = self.road.chain_points(chain, side, at, self.shoulder_m + 0.25)
        b.begin(RANK["rail"], group)
        kinds.guard_rail(b, steel, pts, nrm, pp, pn)

    def _facade(self, b: SolidBuilder, chain: int, side: int, t0: float, t1: float) -> None:
        """A town building with the frontage from ``t0`` to ``t1`` along its chain,
        sides along the road's normals (neighbours abut exactly)."""
        frng = self._rng(chain, side, t0, 8)
        depth = frng.uniform(9.0, 16.0)
        back = self.shoulder_m + self.sidewalk_m + 0.2
        front, _ = self.road.chain_points(chain, side, [t0, t1], back)
        rear, _ = self.road.chain_points(chain, side, [t0, t1], back + depth)
        fp = np.array([front[0], front[1], rear[1], rear[0]])
        if float(np.hypot(*(front[1] - front[0]))) < 5.0 or not self._clear(outline(fp), self.sidewalk_m + 0.1):
            return
        b.begin(RANK["facade"])
        kinds.building(b, frng, fp, int(frng.integers(2, 7)), shop_front=True)

    def _scatter(self, b: SolidBuilder, rng: np.random.Generator, i: int, j: int) -> None:
        """Trees (single or in clumps), houses and signs at random points."""
        p, c = self.profile, self.cell_m
        box = np.array([i * c, j * c])
        # Rates per km of road edge over a band ~25 m wide: per m^2 = rate / 25e3.
        area = c * c / 25_000.0
        sw = self.sidewalk_m
        for _ in range(rng.poisson(self._rate(p.houses_per_km) * area)):
            at = box + rng.random(2) * c
            near = self.road.nearest(at)
            if near is None:
                continue
            heading, _ = near
            fp = rect(at, heading, rng.uniform(8.0, 16.0), rng.uniform(7.0, 12.0))
            d = self.road.distance(at[None], reach=40.0)[0]
            if d < 35.0 and self._clear(outline(fp), sw + 4.0):
                b.begin(RANK["house"])
                kinds.building(b, rng, fp, int(rng.integers(1, 4)))
        pts, shape, radius = [], [], []
        for _ in range(rng.poisson(self._rate(p.trees_per_km) * area)):
            at = box + rng.random(2) * c
            group = [at]
            if rng.random() < p.clump_p:
                group += [at + rng.normal(0, 3.0, 2) for _ in range(int(rng.integers(2, 6)))]
            for q in group:
                shape.append("cone" if rng.random() < p.conifer_p else "round")
                radius.append(kinds.tree_radius(shape[-1], rng.random()))
                pts.append(q)
        if pts:  # one distance query for every trunk and crown outline of the cell
            n, P, R = len(pts), np.asarray(pts), np.asarray(radius)
            ring = (P[:, None, :] + R[:, None, None] * _RING[None]).reshape(-1, 2)
            d = self.road.distance(np.vstack([P, ring]), reach=40.0)
            ok = (d[:n] < 30.0) & (d[n:].reshape(n, len(_RING)).min(axis=1) >= self.shoulder_m + sw + 0.5)
            for k in np.flatnonzero(ok).tolist():
                b.begin(RANK["tree"])
                kinds.tree(b, rng, P[k], shape[k], float(R[k]))
        n_signs = rng.poisson(self._rate(p.signs_per_km) * c / 1000.0)
        e = self.road.edge_samples(i, j, self.shoulder_m + 0.8) if n_signs else np.zeros((0, 10))
        for _ in range(n_signs if len(e) else 0):
            row = e[int(rng.integers(len(e)))]
            # Beside the road, or at the kerb side of a sidewalk (facades stand behind
            # it); the plate (at most 1 m wide, across) never overhangs the shoulder.
            off = self.shoulder_m + 0.6 + (rng.uniform(0.0, 0.3) if sw > 0 else rng.uniform(0.0, 1.0))
            at = row[3:5] + row[6:8] * off
            if self._clear(at[None], 0.55):
                b.begin(RANK["sign"])
                kinds.sign(b, rng, at, float(row[5]) + np.pi, draw_albedo("galvanised_steel", rng))

    def _overpass(self, b: SolidBuilder, rng: np.random.Generator, i: int, j: int) -> None:
        if rng.random() >= min(1.0, self._rate(self.profile.overpass_per_km) * self.cell_m / 1000.0):
            return
        e = self.road.edge_samples(i, j, self.shoulder_m + 0.5)
        if not len(e):
            return
        row = e[int(rng.integers(len(e)))]
        heading, normal = float(row[5]), row[6:8]
        centre = row[3:5] - normal * 2.0  # inside the lane
        ext = self.road.cross_extent(centre, normal, self.shoulder_m + self.sidewalk_m + 1.0)
        if ext is None:
            return
        along = np.array([math.cos(heading), math.sin(heading)]) * 6.0
        pads = np.array([centre + normal * t + a for t in (ext[0] - 2.5, ext[1] + 2.5) for a in (along, -along)])
        if self._clear(pads, self.sidewalk_m + 1.0):
            b.begin(RANK["overpass"])
            kinds.overpass(b, rng, centre, heading, ext[0], ext[1])
