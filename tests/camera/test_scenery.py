"""Scenery: seeded per cell, beside the road (never on a lane or its shoulder), valid convex solids."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from simroad.camera import codes as W
from simroad.camera.scenery import HIGH_M, Scenery
from simroad.envs import RoadCamEnv
from simroad.errors import SimroadError

SCENERY_CODES = {W.VEGETATION, W.POLE, W.SIGN, W.BUILDING, W.WALL, W.GUARDRAIL, W.OVERPASS}


@pytest.fixture(scope="module", params=["racetrack", "highway", "winding"])
def world(request):
    env = RoadCamEnv(scenario=request.param, width=64, height=48, traffic=False)
    env.reset(seed=5)
    yield env.world
    env.close()


def _region(world, size: float = 300.0) -> tuple[float, float, float, float]:
    """A box of ``size`` m from the start of the road."""
    x0, y0, x1, y1 = world.bounds()
    cx = x0 + min(size, x1 - x0) / 2
    return cx - size / 2, y0 - 20, cx + size / 2, min(y1, y0 + size) + 20


def test_the_env_attaches_scenery_with_every_kind(world):
    assert isinstance(world.scenery, Scenery)
    m = world.objects(*_region(world))
    assert len(m) > 200
    codes = set(np.unique(m.material).tolist())
    assert codes <= SCENERY_CODES
    assert {W.VEGETATION, W.POLE} <= codes and len(codes) >= 4


def test_dense_worlds_have_every_kind(world):
    dense = Scenery(world.shapes, 3, density=5.0, shoulder_m=world.palette.shoulder_width_m)
    codes = set(np.unique(dense.meshes(*_region(world, 1200.0)).material).tolist())
    # An overpass needs its abutments clear of every lane: on the compact racetrack
    # (150 m across) the lanes run too close together for most crossings.
    x0, _, x1, _ = world.bounds()
    want = SCENERY_CODES - {W.OVERPASS} if x1 - x0 < 500 else SCENERY_CODES
    assert want <= codes


def test_cells_are_pure_functions_of_seed_and_index(world):
    shoulder = world.palette.shoulder_width_m
    a, b = (Scenery(world.shapes, 9, shoulder_m=shoulder) for _ in range(2))
    cells = [(i, j) for i in range(-2, 4) for j in range(-2, 3)]
    ma = {c: a.cell(*c) for c in cells}
    mb = {c: b.cell(*c) for c in reversed(cells)}
    assert sum(len(m) for m in ma.values()) > 50
    for c in cells:
        np.testing.assert_array_equal(ma[c].vertices, mb[c].vertices)
        np.testing.assert_array_equal(ma[c].albedo, mb[c].albedo)
    other = Scenery(world.shapes, 10, shoulder_m=shoulder)
    assert any(len(other.cell(*c)) != len(ma[c]) for c in cells)


def test_nothing_stands_on_a_lane_or_its_shoulder(world):
    """Every solid reaching below HIGH_M has its ground footprint (the hull of its
    vertices) outside every lane surface and shoulder of the world raster."""
    box = _region(world)
    m = world.objects(*box)
    win = world.window(*box, slot="scenery-test")
    road = np.isin(win.material, [W.ASPHALT, W.MARKING, W.SHOULDER]).astype(np.uint8)
    low = 0
    for sid in np.unique(m.solid):
        faces = m.vertices[m.solid == sid].reshape(-1, 3)
        if faces[:, 2].min() >= HIGH_M:
            continue  # an overpass deck, a light's arm, a street tree's crown
        low += 1
        px = (faces[:, :2] - (win.x0, win.y0)) / win.texel_m - 0.5
        c0, r0 = np.floor(px.min(axis=0)).astype(int) - 2
        c1, r1 = np.ceil(px.max(axis=0)).astype(int) + 2
        if c0 < 0 or r0 < 0 or c1 > road.shape[1] or r1 > road.shape[0]:
            continue  # reaches out of the checked window
        hull = cv2.convexHull(np.round((px - (c0, r0)) * 16).astype(np.int32))
        mask = np.zeros((r1 - r0, c1 - c0), np.uint8)
        cv2.fillConvexPoly(mask, hull, 1, cv2.LINE_8, 4)
        # One texel of tolerance for the raster's own rounding.
        mask = cv2.erode(mask, np.ones((3, 3), np.uint8))
        assert not (mask & road[r0:r1, c0:c1]).any(), (
            sid,
            faces[:, :2].mean(0),
            set(m.material[m.solid == sid].tolist()),
        )
    assert low > 50


def test_solids_are_closed_convex_and_outward(world):
    m = world.objects(*_region(world, 300.0))
    assert (m.counts >= 3).all()
    np.testing.assert_allclose(np.linalg.norm(m.normal, axis=1), 1.0, atol=1e-9)
    k = np.arange(16)[None, :] < m.counts[:, None]
    centre = (m.vertices * k[..., None]).sum(1) / m.counts[:, None]
    # Planar faces: every corner on the face's plane.
    off = ((m.vertices - centre[:, None]) * m.normal[:, None]).sum(-1)
    assert np.abs(off).max() < 1e-6
    # Convex and outward: every vertex of a solid lies behind each of its faces' planes.
    for sid in np.unique(m.solid)[:400]:
        sel = m.solid == sid
        pts = m.vertices[sel].reshape(-1, 3)
        d = np.einsum("fvk,fk->fv", pts[None] - centre[sel][:, None], m.normal[sel])
        assert d.max() < 1e-6, sid
    assert m.albedo.dtype == np.float32 and (m.albedo >= 0).all() and (m.albedo <= 1).all()


def test_density_zero_is_a_bare_world_and_bad_values_are_refused(world):
    s = Scenery(world.shapes, 1, density=0.0)
    assert len(s.meshes(*_region(world))) == 0
    with pytest.raises(SimroadError, match="density"):
        Scenery(world.shapes, 1, density=6.0)
    with pytest.raises(SimroadError, match="profile"):
        Scenery(world.shapes, 1, profile="lunar")


def test_a_town_street_has_continuous_facades_behind_the_sidewalk():
    sidewalk, shoulder = 3.0, 0.5
    s = Scenery(None, 4, profile="urban", shoulder_m=shoulder, sidewalk_m=sidewalk)
    m = s.meshes(0.0, -40.0, 400.0, 40.0)
    b = m.select(m.material == W.BUILDING)
    assert len(b) > 50
    # A straight road along x: road + shoulder within |y| <= 5 m (RoadIndex default).
    ys = np.abs(b.vertices[..., 1])
    assert ys.min() >= 5.0 + sidewalk - 1e-6
    # Facade fronts cover most of the street's length on both sides.
    for sign in (-1, 1):
        side = b.vertices[(np.sign(b.vertices[:, 0, 1]) == sign)]
        xs = np.unique(np.round(side[..., 0].ravel()))
        covered = np.zeros(400, bool)
        for f in side:
            lo, hi = np.clip([f[:, 0].min(), f[:, 0].max()], 0, 400).astype(int)
            covered[lo:hi] = True
        assert covered.mean() > 0.6, (sign, covered.mean(), len(xs))
    trees = m.select(m.material == W.VEGETATION)
    assert len(trees)
    trunks_low = trees.vertices[..., 2].min(axis=1) < 0.01
    # Street trees stand at the kerb side of the sidewalk, not on the road.
    assert np.abs(trees.vertices[trunks_low][..., 1]).min() >= 5.0


def test_every_solid_stays_within_reach_of_its_cell(world):
    """``meshes(box)`` finds a solid from the cells within ``_MARGIN_M`` of the box."""
    from simroad.camera.scenery import _MARGIN_M

    dense = Scenery(world.shapes, 8, density=5.0, shoulder_m=world.palette.shoulder_width_m)
    c = dense.cell_m
    x0, y0, x1, y1 = _region(world, 600.0)
    for i in range(math.floor(x0 / c), math.floor(x1 / c) + 1):
        for j in range(math.floor(y0 / c), math.floor(y1 / c) + 1):
            v = dense.cell(i, j).vertices
            if len(v):
                assert v[..., 0].min() >= i * c - _MARGIN_M and v[..., 0].max() <= (i + 1) * c + _MARGIN_M
                assert v[..., 1].min() >= j * c - _MARGIN_M and v[..., 1].max() <= (j + 1) * c + _MARGIN_M


def _separated(m, fa: np.ndarray, fb: np.ndarray) -> bool:
    """Exact separating-axis test of two convex solids given by their faces ``fa``,
    ``fb`` of mesh ``m``: face normals of either, and cross products of edges."""
    ea, eb = _edges(m, fa), _edges(m, fb)
    cross = np.cross(ea[:, None], eb[None]).reshape(-1, 3)
    norm = np.linalg.norm(cross, axis=1)
    ax = np.concatenate([m.normal[fa], m.normal[fb], cross[norm > 1e-9] / norm[norm > 1e-9, None]])
    va, vb = m.vertices[fa].reshape(-1, 3), m.vertices[fb].reshape(-1, 3)
    a, b = va @ ax.T, vb @ ax.T
    gap = np.maximum(b.min(0) - a.max(0), a.min(0) - b.max(0))
    return bool(gap.max() > -0.02)


def _edges(m, faces: np.ndarray) -> np.ndarray:
    """Distinct unit edge directions of the faces (padding repeats give none)."""
    v = m.vertices[faces]
    d = (np.roll(v, -1, axis=1) - v).reshape(-1, 3)
    n = np.linalg.norm(d, axis=1)
    d = d[n > 1e-6] / n[n > 1e-6, None]
    return np.unique(np.round(d * np.where(d[:, :1] < 0, -1.0, 1.0), 5), axis=0)


@pytest.mark.parametrize("scenario", ["racetrack", "highway", "winding", "town"])
def test_no_two_objects_intersect(scenario):
    """Over several worlds and dense scenery: solids of different objects (tree
    crowns excepted among themselves) are disjoint convex solids, across cells."""
    env = RoadCamEnv(scenario=scenario, width=64, height=48, traffic=False)
    pairs = 0
    for seed in range(4):
        env.reset(seed=seed)
        w = env.world
        s = w.scenery
        dense = Scenery(w.shapes, 100 + seed, profile=s.profile_name, density=2.0 + seed % 2,
                        shoulder_m=s.shoulder_m, sidewalk_m=s.sidewalk_m)  # fmt: skip
        x0, y0, x1, y1 = w.bounds()
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        box = (
            (cx - 150, cy - 150, cx + 150, cy + 150)
            if seed % 2
            else (x0 - 5, y0 - 5, min(x1, x0 + 300), min(y1, y0 + 300))
        )
        m = dense.meshes(*box)
        key, crown = dense.solid_objects(*box)
        ids = np.unique(m.solid)
        lo, hi = np.full((len(key), 3), np.inf), np.full((len(key), 3), -np.inf)
        np.minimum.at(lo, m.solid, m.vertices.min(1))
        np.maximum.at(hi, m.solid, m.vertices.max(1))
        lo, hi = lo[ids], hi[ids]
        near = ((lo[:, None] < hi[None] - 0.02) & (hi[:, None] > lo[None] + 0.02)).all(-1)
        near &= key[ids][:, None] != key[ids][None]
        near &= ~(crown[ids][:, None] & crown[ids][None])
        for a, b in zip(*np.nonzero(np.triu(near, 1))):
            fa, fb = np.flatnonzero(m.solid == ids[a]), np.flatnonzero(m.solid == ids[b])
            ok = _separated(m, fa, fb)
            where = m.vertices[fa].reshape(-1, 3).mean(0)
            assert ok, (scenario, seed, set(m.material[fa].tolist()), set(m.material[fb].tolist()), where)
            pairs += 1
    env.close()
    assert pairs > 20, pairs
