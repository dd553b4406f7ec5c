"""Vehicles as meshes: convex solids, real paint shares, the image region a car covers."""

from __future__ import annotations

import numpy as np

from simroad.camera import VEHICLE, CameraConfig, PinholeCamera, VehicleBox
from simroad.camera._painter import MeshPainter
from simroad.camera.vehicles import PAINTS, draw_paint, paint_rgb, vehicle_mesh, vehicles_mesh


def _car(x=20.0, y=0.0, heading=0.0, paint=(0.5, 0.5, 0.5)):
    return VehicleBox(x, y, heading, 5.0, 2.0, paint_rgb(np.array(paint)), paint=paint)


def test_every_solid_is_convex_with_planar_faces_and_outward_normals():
    m = vehicle_mesh(_car(heading=0.7))
    for s in np.unique(m.solid):
        faces = np.flatnonzero(m.solid == s)
        pts = np.vstack([m.vertices[f, : m.counts[f]] for f in faces])
        for f in faces:
            n, p0 = m.normal[f], m.vertices[f, 0]
            np.testing.assert_allclose(np.linalg.norm(n), 1.0, atol=1e-9)
            on = (m.vertices[f, : m.counts[f]] - p0) @ n
            np.testing.assert_allclose(on, 0.0, atol=1e-9)  # planar
            assert np.all((pts - p0) @ n <= 1e-9)  # the solid lies behind every face
    assert len(np.unique(m.solid)) == 1 + 1 + 8  # body, cabin, 4 wheels of two parts
    assert np.all(m.material == VEHICLE)


def test_paint_draws_follow_the_table():
    rng = np.random.default_rng(0)
    n = 20000
    names = [draw_paint(rng)[0] for _ in range(n)]
    keys = list(PAINTS)
    observed = np.array([names.count(k) for k in keys])
    expected = n * np.array([PAINTS[k].share for k in keys])
    chi2 = float(((observed - expected) ** 2 / expected).sum())
    assert chi2 < 24.3, (chi2, dict(zip(keys, observed)))  # df = 7, p = 0.001
    assert abs(sum(p.share for p in PAINTS.values()) - 1.0) < 1e-9


def test_paint_albedos_are_within_their_ranges_and_neutrals_dominate():
    rng = np.random.default_rng(1)
    for _ in range(200):
        name, a = draw_paint(rng)
        p = PAINTS[name]
        assert np.all(a >= np.array(p.lo) - 1e-6) and np.all(a <= np.array(p.hi) + 1e-6)
    neutral = sum(PAINTS[k].share for k in ("white", "black", "grey", "silver"))
    assert neutral >= 0.8
    assert PAINTS["black"].hi[0] <= 0.06 and PAINTS["white"].lo[0] >= 0.6


def test_a_car_ahead_covers_its_projected_box():
    cam = PinholeCamera(CameraConfig(width=320, height=180))
    cam.set_pose(0.0, 0.0, 0.0)
    car = _car(x=15.0, y=0.0)
    m = vehicles_mesh([car])
    c = cam.config
    rgb = np.zeros((c.height, c.width, 3), dtype=np.uint8)
    material = np.zeros((c.height, c.width), dtype=np.uint8)
    fid = MeshPainter(cam).paint(m, rgb, material, cam.depth.copy())
    corners = np.array([[x, y, z] for x in (12.5, 17.5) for y in (-1.0, 1.0) for z in (0.0, 1.5)])
    uv = cam.camera_to_image(cam.world_to_camera(corners))
    u0, v0 = uv.min(axis=0)
    u1, v1 = uv.max(axis=0)
    vv, uu = np.nonzero(fid >= 0)
    assert uu.min() >= u0 - 1 and uu.max() <= u1 + 1 and vv.min() >= v0 - 1 and vv.max() <= v1 + 1
    # The rear of the car (body and cabin) fills the middle of that box.
    rear = [[12.55, y, z] for y in (-0.7, 0.7) for z in (0.4, 1.3)]
    ruv = cam.camera_to_image(cam.world_to_camera(np.array(rear)))
    a, b = np.floor(ruv.min(axis=0)).astype(int) + 1, np.ceil(ruv.max(axis=0)).astype(int) - 1
    assert b[0] - a[0] > 5 and b[1] - a[1] > 5
    assert np.all(material[a[1] : b[1], a[0] : b[0]] == VEHICLE)
    assert (material == VEHICLE).sum() > 0.6 * (u1 - u0) * (v1 - v0)


def test_many_vehicles_make_one_mesh_with_unique_solids():
    cars = [_car(x=10.0 * k, heading=0.3 * k) for k in range(5)]
    m = vehicles_mesh(cars)
    one = vehicle_mesh(cars[0])
    assert len(m) == 5 * len(one)
    assert len(np.unique(m.solid)) == 5 * len(np.unique(one.solid))
    np.testing.assert_allclose(m.vertices[: len(one)], one.vertices)
