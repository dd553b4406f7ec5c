"""The weather models' per-camera constants agree with the camera module."""

from __future__ import annotations

import math

import numpy as np

from simroad.camera import CameraConfig, PinholeCamera
from simroad.noise._geometry import ego_to_world, view_geometry


def test_ego_rotation_and_rays_agree_with_the_camera():
    cam = PinholeCamera(CameraConfig(width=200, height=120, pitch_deg=7.0, mount_height_m=1.4))
    cam.set_pose(10.0, -3.0, math.radians(30.0))
    geom = view_geometry(cam)
    rng = np.random.default_rng(0)
    # Camera-relative ego points -> world (x, y, height) -> camera frame, two ways.
    rel = rng.uniform([1, -3, -1], [20, 3, 1], size=(50, 3))
    ego_xy = rel[:, :2] + [geom.forward_m, 0.0]
    wx, wy = ego_to_world(ego_xy, cam.pose)
    world = np.column_stack([wx, wy, geom.height_m - rel[:, 2]])
    np.testing.assert_allclose(cam.world_to_camera(world), rel @ geom.R_ego.T, atol=1e-9)
    # Every ground pixel's ego ground point is the camera's own image_to_ground.
    rows, cols = np.nonzero(geom.ground)
    pick = rng.choice(len(rows), 200, replace=False)
    uv = np.column_stack([cols[pick], rows[pick]]).astype(float)
    gx, gy = ego_to_world(geom.ground_xy[rows[pick], cols[pick]].astype(float), cam.pose)
    np.testing.assert_allclose(np.column_stack([gx, gy]), cam.image_to_ground(uv), atol=1e-3)


def test_mirror_map_points_above_the_horizon():
    cam = PinholeCamera()
    geom = view_geometry(cam)
    _mx, my = geom.mirror_map
    rows, cols = np.nonzero(geom.ground)
    assert (my[rows, cols] < cam.horizon_row).all()
    # With a small pitch the mirror of a pixel lies about as far above the horizon as
    # the pixel lies below it.
    r = rows[(rows > cam.horizon_row + 5) & (rows < cam.horizon_row + 40)]
    c = cols[(rows > cam.horizon_row + 5) & (rows < cam.horizon_row + 40)]
    np.testing.assert_allclose(cam.horizon_row - my[r, c], r - cam.horizon_row, rtol=0.25, atol=2)
