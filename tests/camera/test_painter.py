"""The mesh painter: occlusion between convex solids, exact depth, culling, clipping."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.camera import CameraConfig, PinholeCamera
from simroad.camera._painter import MeshPainter
from simroad.camera._raster import mesh_data
from simroad.camera.codes import BUILDING, OVERPASS, POLE, VEGETATION, WALL
from simroad.camera.mesh import Mesh
from simroad.camera.vehicles import box_mesh

GREY = (0.3, 0.3, 0.3)


def _camera(width=320, height=180) -> PinholeCamera:
    cam = PinholeCamera(CameraConfig(width=width, height=height))
    cam.set_pose(0.0, 0.0, 0.0)  # camera at world (0.8, 0), looking along +x
    return cam


def _paint(cam: PinholeCamera, mesh: Mesh):
    c = cam.config
    rgb = np.zeros((c.height, c.width, 3), dtype=np.uint8)
    material = np.zeros((c.height, c.width), dtype=np.uint8)
    depth = cam.depth.copy()
    fid = MeshPainter(cam).paint(mesh, rgb, material, depth)
    return fid, rgb, material, depth


def _solid_map(mesh: Mesh, fid: np.ndarray) -> np.ndarray:
    return np.where(fid >= 0, mesh.solid[np.maximum(fid, 0)], -1)


def _box(x, y, length, width, z0, z1, material=BUILDING, heading=0.0):
    return box_mesh(x, y, heading, length, width, z0, z1, albedo=GREY, material=material)


@pytest.mark.parametrize("near_first", [False, True])
def test_near_box_hides_far_box_whatever_the_order(near_first):
    cam = _camera()
    near, far = _box(20, 0, 2, 3, 0, 2), _box(40, 1, 4, 8, 0, 6)
    parts = [near, far] if near_first else [far, near]
    mesh = Mesh.concat(parts)
    near_id = 0 if near_first else 1
    fid, *_ = _paint(cam, mesh)
    solids = _solid_map(mesh, fid)
    alone, *_ = _paint(cam, near)
    covered = alone >= 0
    assert covered.sum() > 100
    assert np.all(solids[covered] == near_id)  # wherever the near box is, it wins
    assert (solids == 1 - near_id).sum() > 100  # and the far one shows around it


def test_pole_in_front_of_a_long_wall_is_seen():
    # The wall's centre is nearer than the pole, yet the pole stands in front of it:
    # ordering by distance would hide the pole; the separating plane does not.
    cam = _camera()
    wall = _box(30.5, 11.0, 60.0, 0.5, 0, 4, material=WALL)
    pole = _box(45.0, 8.0, 0.4, 0.4, 0, 7, material=POLE)
    for parts in ([wall, pole], [pole, wall]):
        mesh = Mesh.concat(parts)
        _, _, material, _ = _paint(cam, mesh)
        alone, *_ = _paint(cam, pole)
        assert (alone >= 0).sum() > 10
        assert np.all(material[alone >= 0] == POLE)


def test_overpass_deck_in_front_of_a_distant_building_and_a_car_under_it():
    cam = _camera()
    deck = _box(35, 0, 8, 40, 5.0, 6.2, material=OVERPASS)
    building = _box(90, 0, 10, 30, 0, 25, material=BUILDING)
    car = _box(36, 0, 4.5, 1.8, 0, 1.5, material=WALL)  # any other code
    for parts in ([deck, building, car], [car, building, deck], [building, car, deck]):
        mesh = Mesh.concat(parts)
        _, _, material, _ = _paint(cam, mesh)
        d_alone, *_ = _paint(cam, deck)
        c_alone, *_ = _paint(cam, car)
        assert np.all(material[d_alone >= 0] == OVERPASS)
        assert np.all(material[c_alone >= 0] == WALL)
        assert (material == BUILDING).sum() > 50


def test_depth_of_a_facing_box_face_is_the_analytic_distance():
    cam = _camera()
    box = _box(25.0, 0.0, 2.0, 6.0, 0.0, 3.0)  # rear face on the plane x = 24
    fid, _, _, depth = _paint(cam, box)
    v, u = np.nonzero(fid >= 0)
    assert len(u) > 200
    c = cam.config
    f = cam.K[0, 0]
    p = math.radians(c.pitch_deg)
    xn, yn = (u - cam.K[0, 2]) / f, (v - cam.K[1, 2]) / f
    # Ray in the ego frame (X forward, Y right, Z down) for a camera pitched down by p.
    rx = -math.sin(p) * yn + math.cos(p)
    ry = xn
    t = (24.0 - c.forward_offset_m) / rx  # reach the plane X = 24 (world x = ego X here)
    expected = t * np.hypot(rx, ry)
    np.testing.assert_allclose(depth[v, u], expected, rtol=1e-4)


def test_back_faces_are_not_drawn():
    cam = _camera()
    box = _box(25.0, 0.0, 2.0, 6.0, 0.0, 3.0)
    fid, *_ = _paint(cam, box)
    C = np.array([*cam.position_world, cam.config.mount_height_m])
    seen = np.unique(fid[fid >= 0])
    facing = np.einsum("fc,fc->f", box.normal, C - box.vertices[:, 0]) > 0
    assert set(seen) <= set(np.flatnonzero(facing))
    # A lone face turned away from the camera is not drawn at all.
    back = box.select(np.flatnonzero(box.normal[:, 0] > 0.5))  # the far face, normal +x
    fid2, *_ = _paint(cam, back)
    assert (fid2 >= 0).sum() == 0


def test_a_box_through_the_near_plane_is_clipped_not_lost():
    cam = _camera()
    side = _box(0.0, 2.5, 20.0, 1.0, 0.0, 3.0, material=WALL)  # from 10 m behind to 10 m ahead, on the right
    fid, _, _, depth = _paint(cam, side)
    covered = fid >= 0
    c = cam.config
    assert covered[:, -1].sum() > c.height // 3  # fills the right edge of the image
    assert not covered[:, : c.width // 3].any()
    assert np.all(np.isfinite(depth[covered])) and depth[covered].min() >= 0.0
    assert depth[covered].max() <= 11.0


def test_faces_behind_the_camera_are_not_drawn():
    cam = _camera()
    fid, *_ = _paint(cam, _box(-20.0, 0.0, 4.0, 4.0, 0.0, 3.0))
    assert (fid >= 0).sum() == 0


def _with_decal(box: Mesh, face: int, shrink: float = 0.25, albedo=(0.05, 0.05, 0.05)) -> Mesh:
    """``box`` plus a window: a smaller copy of ``face`` in its plane, drawn after it."""
    n = box.counts[face]
    poly = box.vertices[face, :n]
    c = poly.mean(axis=0)
    win = np.repeat((c + (1 - shrink) * 0.5 * (poly - c))[-1:], 16, axis=0)
    win[:n] = c + (1 - shrink) * 0.5 * (poly - c)
    return Mesh(
        np.concatenate([box.vertices, win[None]]),
        np.append(box.counts, n).astype(np.int32),
        np.concatenate([box.albedo, np.array([albedo], dtype=np.float32)]),
        np.append(box.material, box.material[face]).astype(np.uint8),
        np.concatenate([box.normal, box.normal[face][None]]),
        np.append(box.solid, box.solid[face]),
    )


def test_decals_are_found_and_add_nothing_to_the_bounding_sphere():
    box = _box(30, 0, 4, 6, 0, 5)
    rear = int(np.argmin(box.normal[:, 0]))  # faces the camera (normal -x)
    m = _with_decal(box, rear)
    args = (m.vertices, m.counts.astype(np.int64), m.normal, m.solid.astype(np.int64))
    offset, _, decal, sphere = mesh_data(*args)
    assert decal.sum() == 1 and decal[6]  # the window, not its facade
    np.testing.assert_allclose(sphere[0], [30, 0, 2.5, math.sqrt(2**2 + 3**2 + 2.5**2)])
    np.testing.assert_allclose(offset, np.einsum("fc,fc->f", m.normal, m.vertices[:, 0]))


def test_a_window_is_drawn_on_its_facade_and_hides_nothing_else():
    cam = _camera()
    box = _box(30, 0, 4, 6, 0, 5)
    rear = int(np.argmin(box.normal[:, 0]))
    mesh = Mesh.concat([_with_decal(box, rear), _box(20, 0, 1, 1, 0, 1, material=POLE)])
    fid, _, material, depth = _paint(cam, mesh)
    win = fid == 6
    assert win.sum() > 50
    assert (material == POLE).sum() > 20  # the pole in front still shows
    # The window's depth is its facade's depth (the same plane).
    _, _, _, d_box = _paint(cam, box)
    np.testing.assert_allclose(depth[win], d_box[win], rtol=1e-5)


def test_a_tree_in_front_of_a_facade_and_a_pole_beside_it():
    cam = _camera()
    # Along the road, on the right, clear of the tree (y in 4.6..14.6 vs 2.5..4.5: were
    # they to intersect, the part of the tree inside the building would be hidden).
    facade = _box(40, 9.6, 30, 10, 0, 12, material=BUILDING)
    tree = _box(33, 3.5, 2, 2, 0, 5, material=VEGETATION)
    pole = _box(50, 2.5, 0.3, 0.3, 0, 6, material=POLE)
    for parts in ([facade, tree, pole], [pole, tree, facade], [tree, facade, pole]):
        mesh = Mesh.concat(parts)
        _, _, material, _ = _paint(cam, mesh)
        for part, code in ((tree, VEGETATION), (pole, POLE)):
            alone, *_ = _paint(cam, part)
            assert (alone >= 0).sum() > 10
            assert np.all(material[alone >= 0] == code)


def test_subpixel_faces_are_not_drawn():
    cam = _camera()
    far = _box(90, 0, 0.02, 0.02, 0, 0.02)  # 2 cm at 90 m: a tenth of a pixel
    fid, *_ = _paint(cam, far)
    assert (fid >= 0).sum() == 0


def test_paint_parts_returns_the_drawn_faces_it_indexes():
    cam = _camera()
    c = cam.config
    a, b = _box(30, 0, 4, 6, 0, 5), _box(20, 2, 2, 2, 0, 2, material=POLE)
    rgb = np.zeros((c.height, c.width, 3), dtype=np.uint8)
    material = np.zeros((c.height, c.width), dtype=np.uint8)
    depth = cam.depth.copy()
    fid, faces = MeshPainter(cam).paint_parts([a, Mesh.empty(), b], rgb, material, depth)
    on = fid >= 0
    assert on.sum() > 100 and len(faces) <= len(a) + len(b)
    np.testing.assert_array_equal(faces.material[fid[on]], material[on])
    assert set(np.unique(faces.solid)) == {0, 1}  # solid ids as Mesh.concat numbers them
    # Same pixels as one painted concatenation.
    ref, *_ = _paint(cam, Mesh.concat([a, b]))
    np.testing.assert_array_equal(ref >= 0, on)


def test_intersecting_solids_are_exact_per_pixel():
    # A trunk into a crown (two solids that intersect): the part of the trunk inside
    # the crown is hidden, the part below it is seen, and where the trunk passes the
    # crown's underside it hides the underside; no order of the solids does all three.
    cam = _camera()
    crown = _box(30, 0, 4, 4, 3, 7, material=VEGETATION)
    trunk = _box(30, 0, 0.5, 0.5, 0, 6, material=POLE)
    c_alone, _, _, d_crown = _paint(cam, crown)
    t_alone, _, _, d_trunk = _paint(cam, trunk)
    both = (c_alone >= 0) & (t_alone >= 0)
    crown_first = both & (d_crown < 0.999 * d_trunk)
    trunk_first = both & (d_trunk < 0.999 * d_crown)
    assert crown_first.sum() > 50 and trunk_first.sum() > 0
    for parts in ([crown, trunk], [trunk, crown]):
        _, _, material, depth = _paint(cam, Mesh.concat(parts))
        assert np.all(material[crown_first] == VEGETATION)
        assert np.all(material[trunk_first] == POLE)
        np.testing.assert_array_equal(depth[both], np.minimum(d_crown, d_trunk)[both])
        below = (t_alone >= 0) & (c_alone < 0)
        assert below.sum() > 20 and np.all(material[below] == POLE)


def test_a_thin_pole_far_away_is_not_lost():
    cam = _camera()
    pole = _box(80, 3, 0.12, 0.12, 0, 8, material=POLE)  # a third of a pixel wide
    _, _, material, _ = _paint(cam, pole)
    rows = np.flatnonzero((material == POLE).any(axis=1))
    assert len(rows) >= 10 and np.all(np.diff(rows) == 1)  # an unbroken line


def test_same_mesh_same_frame():
    cam = _camera()
    mesh = Mesh.concat([_box(30, 0, 4, 6, 0, 5), _box(20, 2, 1, 1, 0, 3, material=POLE)])
    a, b = _paint(cam, mesh), _paint(cam, mesh)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
