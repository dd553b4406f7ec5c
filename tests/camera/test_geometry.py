"""Pinhole geometry against cases worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.camera import CameraConfig, PinholeCamera


def _cam(**kw) -> PinholeCamera:
    return PinholeCamera(CameraConfig(**kw))


def test_intrinsics_from_fov_by_hand():
    cam = _cam(width=320, height=180, hfov_deg=90.0)
    # tan(45 deg) = 1, so fx = 160 px; principal point at the centre of pixel centres.
    assert cam.K[0, 0] == pytest.approx(160.0)
    assert cam.K[0, 2] == pytest.approx(159.5)
    assert cam.K[1, 2] == pytest.approx(89.5)


def test_point_straight_ahead_projects_to_the_hand_computed_row():
    h, pitch, off = 1.5, 6.0, 0.0
    cam = _cam(width=320, height=180, hfov_deg=90.0, mount_height_m=h, pitch_deg=pitch, forward_offset_m=off)
    cam.set_pose(0.0, 0.0, 0.0)
    d = 20.0
    uv = cam.ground_to_image([[d, 0.0]])[0]
    # Depression angle atan(h/d) below the horizon, the axis is pitch below it.
    expected_row = 89.5 + 160.0 * math.tan(math.atan(h / d) - math.radians(pitch))
    assert uv[0] == pytest.approx(159.5)
    assert uv[1] == pytest.approx(expected_row)
    assert cam.horizon_row == pytest.approx(89.5 - 160.0 * math.tan(math.radians(pitch)))


def test_right_of_heading_is_right_in_the_image_for_any_heading():
    cam = _cam()
    for heading in (0.0, 0.7, math.pi / 2, -2.5):
        cam.set_pose(10.0, -4.0, heading)
        fwd = np.array([math.cos(heading), math.sin(heading)])
        right = np.array([-math.sin(heading), math.cos(heading)])  # highway-env lateral +
        base = np.array([10.0, -4.0]) + 15.0 * fwd
        u_centre, u_right = cam.ground_to_image(np.array([base, base + 2.0 * right]))[:, 0]
        assert u_right > u_centre + 5


def test_image_ground_round_trip():
    cam = _cam(width=640, height=360)
    cam.set_pose(3.0, 7.0, 0.4)
    rng = np.random.default_rng(0)
    uv = np.column_stack([rng.uniform(0, 639, 500), rng.uniform(cam.horizon_row + 5, 359, 500)])
    xy = cam.image_to_ground(uv)
    ok = ~np.isnan(xy[:, 0])
    assert ok.mean() > 0.9
    back = cam.ground_to_image(xy[ok])
    np.testing.assert_allclose(back, uv[ok], atol=1e-6)


def test_above_horizon_and_beyond_range_are_nan():
    cam = _cam(max_range_m=50.0)
    above = cam.image_to_ground([[100.0, cam.horizon_row - 3]])
    assert np.isnan(above).all()
    # Row just below the horizon sees ground farther than 50 m.
    far = cam.image_to_ground([[160.0, cam.horizon_row + 0.5]])
    assert np.isnan(far).all()


def test_depth_is_the_ground_distance_from_the_camera():
    cam = _cam()
    cam.set_pose(0.0, 0.0, 0.0)
    v, u = np.nonzero(cam.ground_valid)
    pick = np.random.default_rng(1).choice(len(u), 200, replace=False)
    xy = cam.image_to_ground(np.column_stack([u[pick], v[pick]]).astype(float))
    cx, cy = cam.position_world
    np.testing.assert_allclose(cam.depth[v[pick], u[pick]], np.hypot(xy[:, 0] - cx, xy[:, 1] - cy), rtol=1e-5)
    assert np.isinf(cam.depth[0]).all()  # top row is sky


def test_world_to_camera_height_goes_up_in_the_image():
    cam = _cam()
    cam.set_pose(0.0, 0.0, 0.0)
    pts = cam.camera_to_image(cam.world_to_camera([[20.0, 0.0, 0.0], [20.0, 0.0, 2.0]]))
    assert pts[1, 1] < pts[0, 1]


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"width": 2000}, "width"),
        ({"height": 8}, "height"),
        ({"hfov_deg": 170}, "hfov_deg"),
        ({"pitch_deg": -20}, "pitch_deg"),
        ({"pitch_deg": float("nan")}, "pitch_deg"),
    ],
)
def test_out_of_range_camera_options_name_the_parameter_and_range(kw, name):
    with pytest.raises(SimroadError, match=name) as err:
        CameraConfig(**kw)
    assert "expected" in str(err.value)


def test_points_must_be_n_by_2():
    with pytest.raises(SimroadError, match="uv"):
        _cam().image_to_ground(np.zeros((4, 3)))


@pytest.mark.parametrize("bad", ["abc", [["a", "b"]], [[1.0, 2.0], [3.0]], {"x": 1}])
def test_points_that_are_not_numbers_are_refused_by_name(bad):
    cam = PinholeCamera(CameraConfig())
    for method, name in ((cam.ground_to_image, "xy"), (cam.image_to_ground, "uv")):
        with pytest.raises(SimroadError, match=f"{name}: expected numbers of shape"):
            method(bad)


def test_non_finite_points_map_to_nan_and_leave_the_others_alone():
    cam = PinholeCamera(CameraConfig())
    good_xy, good_uv = [[20.0, 1.0]], [[100.0, 150.0]]
    xy = cam.ground_to_image([[np.nan, 0.0], [np.inf, 0.0], *good_xy])
    uv = cam.image_to_ground([[np.nan, 100.0], [-np.inf, 150.0], *good_uv])
    assert np.isnan(xy[:2]).all() and np.isnan(uv[:2]).all()
    # the same values (to the last bits: BLAS may sum a 3-row product in another order)
    np.testing.assert_allclose(xy[2:], cam.ground_to_image(good_xy), rtol=1e-12)
    np.testing.assert_allclose(uv[2:], cam.image_to_ground(good_uv), rtol=1e-12)
