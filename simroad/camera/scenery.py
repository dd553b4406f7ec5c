"""Scenery of the world: trees, poles, signs, buildings, walls, guard rails, overpasses.

The world is cut into square cells (``cell_m``). The objects of cell (i, j) are
drawn from a generator seeded by ``(seed, i, j)`` only, so a cell's contents never
depend on which cells were visited before; each object belongs to the cell of its
anchor point. Two kinds of placement:

* **along the road** -- the road's outer edge lines (:mod:`._scenery_road`) are
  cut into stretches of ``STRETCH_M``; each stretch of each edge decides from its
  own generator (seeded by ``(seed, lane, side, stretch)``, so a run continues
  across cells) whether it carries a guard rail, a wall, a line of street lights,
  a row of town facades or street trees;
* **scattered** -- trees (partly in clumps), houses and signs at Poisson-drawn
  points at a distance from the road typical of their kind; overpasses cross the
  road at a random edge sample.

Nothing stands on a lane or its shoulder (nor, in a town, on the sidewalk except
street trees and lamp posts at its kerb side): every solid reaching below :data:`HIGH_M`
(3 m) is accepted only if all its ground corners are at least ``shoulder_m`` (plus
the sidewalk in towns) from every lane surface. Only overpass decks, street-light
arms and the crowns of street trees, all higher, reach over it.

Densities per profile are :data:`PROFILES` (per km of road edge, per stretch);
``density`` scales them (0 = nothing, 1 = the profile's, up to 5).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from simroad._validation import check_choice, check_in_range
from simroad.camera import _scenery_kinds as kinds
from simroad.camera._scenery_road import EDGE_STEP_M, RoadIndex
from simroad.camera._scenery_solids import SolidBuilder, rect
from simroad.camera.materials import draw_albedo
from simroad.camera.mesh import Mesh

__all__ = ["HIGH_M", "PROFILES", "STRETCH_M", "Scenery", "SceneryProfile"]

#: Length of the road-edge stretches that decide rails, walls, lights, facades, m.
STRETCH_M = 120.0
_MARGIN_M = 45.0  # largest reach of an object beyond its anchor's cell (overpass decks), m
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
        self._cells: OrderedDict[tuple[int, int], Mesh] = OrderedDict()
        self._last: tuple[tuple[int, int, int, int] | None, Mesh] = (None, Mesh.empty())

    # ------------------------------------------------------------------ API
    def meshes(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Mesh:
        """Every solid that may reach into the world box (metres), as one mesh."""
        c, m = self.cell_m, _MARGIN_M
        key = (
            math.floor((xmin - m) / c),
            math.floor((ymin - m) / c),
            math.floor((xmax + m) / c),
            math.floor((ymax + m) / c),
        )
        if self._last[0] != key:
            i0, j0, i1, j1 = key
            parts = [self.cell(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]
            self._last = (key, Mesh.concat(parts))
        return self._last[1]

    def cell(self, i: int, j: int) -> Mesh:
        """The solids anchored in world cell (i, j) (cached; a pure function of the
        seed and the cell index)."""
        key = (i, j)
        hit = self._cells.get(key)
        if hit is not None:
            self._cells.move_to_end(key)
            return hit
        out = self._build(i, j)
        self._cells[key] = out
        if len(self._cells) > self.max_cells:
            self._cells.popitem(last=False)
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

    def _build(self, i: int, j: int) -> Mesh:
        if self.density == 0.0:
            return Mesh.empty()
        b = SolidBuilder()
        rng = np.random.default_rng([self.seed, i + 2**31, j + 2**31])
        self._along_road(b, i, j)
        self._scatter(b, rng, i, j)
        self._overpass(b, rng, i, j)
        return b.mesh()

    def _stretch_rng(self, lane: int, side: int, k: int, what: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, 1 + what, lane, side + 1, k + 2**31])

    def _along_road(self, b: SolidBuilder, i: int, j: int) -> None:
        """Rails, walls, light lines, facades and street trees of the cell's edges."""
        p, sh, sw = self.profile, self.shoulder_m, self.sidewalk_m
        e = self.road.edge_samples(i, j, sh + sw + 0.5)
        for row_k, row in enumerate(e):
            lane, side, s = int(row[0]), int(row[1]), float(row[2])
            chain, sg = int(row[8]), float(row[9])  # stretches run along the lane chain
            base, normal = row[3:5], row[6:8]
            nxt = e[min(row_k + 1, len(e) - 1)]
            same = row_k + 1 < len(e) and nxt[0] == lane and nxt[1] == side
            joined = same and abs(nxt[2] - s - EDGE_STEP_M) < 1.0
            k = int(sg // STRETCH_M)
            st = self._stretch_rng(chain, side, k, 0)
            u = st.random(6)
            if joined and u[0] < self._p(p.rail_p) and sw == 0.0:
                p0, p1 = base + normal * (sh + 0.25), nxt[3:5] + nxt[6:8] * (sh + 0.25)
                if self._clear(np.array([p0, p1]), 0.2):
                    kinds.guard_rail(b, draw_albedo("galvanised_steel", st), p0, p1, normal)
            if joined and u[1] < self._p(p.wall_p):  # behind a rail, if there is one
                off = sh + sw + 1.0 + 2.0 * u[2]
                p0, p1 = base + normal * off, nxt[3:5] + nxt[6:8] * off
                if self._clear(np.array([p0, p1]), sw + 0.9):
                    brick = ("concrete", "brick")[int(u[3] < 0.3)]
                    kinds.wall(b, draw_albedo(brick, st), p0, p1, normal, 2.0 + 2.0 * u[4])
            if s >= self.road.lane_length(lane) - 1e-6:
                continue  # a lane's last sample: the next lane of the chain starts here
            self._point_objects(b, row, u[5], k)

    def _point_objects(self, b: SolidBuilder, row: np.ndarray, u_light: float, k: int) -> None:
        """Street lights, street trees and facades at one edge sample."""
        p, sh, sw = self.profile, self.shoulder_m, self.sidewalk_m
        side, chain, sg = int(row[1]), int(row[8]), float(row[9])
        base, heading, normal = row[3:5], float(row[5]), row[6:8]
        at_s = sg - k * STRETCH_M  # position within the stretch
        key = int(round(sg / EDGE_STEP_M))  # this sample along the chain
        if u_light < self._p(p.lights_p):
            spacing = float(self._stretch_rng(chain, side, k, 1).uniform(28.0, 42.0))
            if at_s % spacing < EDGE_STEP_M:
                lrng = self._stretch_rng(chain, side, key, 2)
                at = base + normal * (sh + (0.6 if sw > 0 else 0.8 + 0.8 * lrng.random()))
                if self._clear(at[None], 0.3):
                    steel = draw_albedo("galvanised_steel", self._stretch_rng(chain, side, k, 3))
                    arm = lrng.random() < p.light_arm_p
                    kinds.street_light(b, lrng, at, -normal, steel, arm=arm)
        if sw > 0 and self._stretch_rng(chain, side, k, 4).random() < self._p(p.street_trees_p):
            spacing = float(self._stretch_rng(chain, side, k, 5).uniform(9.0, 15.0))
            if (at_s + 5.0) % spacing < EDGE_STEP_M:
                trng = self._stretch_rng(chain, side, key, 6)
                r = kinds.tree_radius("round", trng.random() * 0.4)
                kinds.tree(b, trng, base + normal * (sh + 0.7), "round", r, crown_bottom_m=HIGH_M)
        if sw > 0 and self._stretch_rng(chain, side, k, 7).random() < self._p(p.facade_p):
            self._facade(b, chain, side, key, base, heading, normal)

    def _facade(self, b: SolidBuilder, chain: int, side: int, key: int, base, heading, normal) -> None:
        """A town building whose frontage starts at edge sample ``key`` of its chain:
        frontages of 12 m follow one another along the stretch without gaps."""
        frng = self._stretch_rng(chain, side, key, 8)
        if key % 3:  # a frontage every 3 samples (12 m)
            return
        front = 3 * EDGE_STEP_M
        depth = frng.uniform(9.0, 16.0)
        back = self.shoulder_m + self.sidewalk_m + 0.2
        centre = base + normal * (back + depth / 2) + np.array([math.cos(heading), math.sin(heading)]) * front / 2
        corners = rect(centre, heading, front, depth)
        if not self._clear(np.vstack([corners, centre[None]]), self.sidewalk_m + 0.1):
            return
        floors = int(frng.integers(2, 7))
        kinds.building(b, frng, centre, heading, front, depth, floors, shop_front=True)

    def _scatter(self, b: SolidBuilder, rng: np.random.Generator, i: int, j: int) -> None:
        """Trees (single or in clumps), houses and signs at random points."""
        p, c = self.profile, self.cell_m
        box = np.array([i * c, j * c])
        # Rates per km of road edge over a band ~25 m wide: per m^2 = rate / 25e3.
        area = c * c / 25_000.0
        sw = self.sidewalk_m
        placed: list[tuple[np.ndarray, float, float, float]] = []  # houses: centre, heading, half sizes
        for _ in range(rng.poisson(self._rate(p.houses_per_km) * area)):
            at = box + rng.random(2) * c
            near = self.road.nearest(at)
            if near is None:
                continue
            heading, _ = near
            front, depth = rng.uniform(8.0, 16.0), rng.uniform(7.0, 12.0)
            corners = rect(at, heading, front, depth)
            d = self.road.distance(at[None], reach=40.0)[0]
            if d < 35.0 and self._clear(np.vstack([corners, at[None]]), sw + 4.0):
                kinds.building(b, rng, at, heading, front, depth, int(rng.integers(1, 4)))
                placed.append((at, heading, front / 2 + 0.5, depth / 2 + 0.5))
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
            for at, heading, hx, hy in placed:  # no crown in a house's walls
                rel = P - at
                lx = np.abs(rel @ np.array([math.cos(heading), math.sin(heading)]))
                ly = np.abs(rel @ np.array([-math.sin(heading), math.cos(heading)]))
                ok &= (lx > hx + R) | (ly > hy + R)
            for k in np.flatnonzero(ok).tolist():
                kinds.tree(b, rng, P[k], shape[k], float(R[k]))
        n_signs = rng.poisson(self._rate(p.signs_per_km) * c / 1000.0)
        e = self.road.edge_samples(i, j, self.shoulder_m + 0.8) if n_signs else np.zeros((0, 10))
        for _ in range(n_signs if len(e) else 0):
            row = e[int(rng.integers(len(e)))]
            # Beside the road, or at the kerb side of a sidewalk (facades stand behind it).
            off = self.shoulder_m + (rng.uniform(0.3, 0.6) if sw > 0 else rng.uniform(0.5, 1.5))
            at = row[3:5] + row[6:8] * off
            if self._clear(at[None], 0.2):
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
            kinds.overpass(b, rng, centre, heading, ext[0], ext[1])
