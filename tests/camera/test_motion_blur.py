"""Motion blur: the ground blurred in the world's texture against the mean of still
frames along the exposure, the box kernel by hand, and the sensor's share of the blur."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest
from highway_env.road.lane import LineType, StraightLane
from highway_env.road.road import RoadNetwork

from simroad.camera import CameraConfig, CameraRenderer, PinholeCamera, SensorParams, WorldRaster
from simroad.camera._blur_kernel import _plan_depth, _plan_flat, decode, radial_blur, radial_blur_depth
from simroad.camera._ground_blur import RowBlur, _tables, blur_start_row, box_blur_texture, row_blur_px, segment_kernel
from simroad.camera._sensor_ops import inv_cos_bearing, motion_blur_scale, near_edge_maps
from simroad.camera.sensor import apply_sensor
from simroad.core.radiometry import srgb_to_linear
from simroad.errors import SimroadError


def _renderer(size=(320, 180), seed=3) -> CameraRenderer:
    net = RoadNetwork()
    line = (LineType.CONTINUOUS, LineType.STRIPED)
    for k in range(2):
        net.add_lane("a", "b", StraightLane([0, 4.0 * k], [400, 4.0 * k], width=4.0, line_types=line))
    rng = np.random.default_rng(seed)
    world = WorldRaster(net, rng)
    return CameraRenderer(PinholeCamera(CameraConfig(width=size[0], height=size[1])), world, rng)


@pytest.mark.parametrize("heading", [0.0, 0.6])
def test_ground_blur_is_the_mean_of_still_frames_along_the_exposure(heading):
    # Independent reference: the light a pixel gathers while the camera moves from
    # pose - travel * heading to pose, as the mean of 48 still frames (linear light).
    r = _renderer()
    x, y, travel = 60.0, 2.0, 0.5
    c, s = math.cos(heading), math.sin(heading)
    blurred = r.render((x, y, heading), motion_m=travel)
    acc = np.zeros(blurred.rgb.shape, np.float64)
    ts = np.linspace(0.0, 1.0, 48)
    for t in ts:
        acc += srgb_to_linear(r.render((x - t * travel * c, y - t * travel * s, heading)).rgb)
    ref = acc / len(ts)
    still = srgb_to_linear(r.render((x, y, heading)).rgb)
    got = srgb_to_linear(blurred.rgb)
    rows = slice(r._r1 + 10, None)  # ground, not the faded horizon
    err = np.abs(got - ref)[rows].mean()
    moved = np.abs(still - ref)[rows].mean()
    assert moved > 4 * err  # the blur is real ...
    # ... and it is the exposure's, to the 8-bit rounding of the blurred texture
    # (linear units, 1.0 = white; 3e-3 is under one code at mid-grey).
    assert err < 3e-3
    # Ground truth does not blur: the road mask is the still frame's.
    assert np.array_equal(blurred.road_mask, r.render((x, y, heading)).road_mask)
    assert blurred.motion_m == travel


def test_zero_motion_is_the_still_frame_and_bad_motion_is_refused():
    r = _renderer()
    a, b = r.render((60.0, 2.0, 0.0)), r.render((60.0, 2.0, 0.0), motion_m=0.0)
    assert np.array_equal(a.rgb, b.rgb)
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(SimroadError, match="motion_m"):
            r.render((60.0, 2.0, 0.0), motion_m=bad)


def test_segment_kernel_by_hand():
    # A shift of one texel along x: the bilinear weights of t in [0, 1] average to
    # one half on each texel.
    k, anchor = segment_kernel((1.0, 0.0))
    np.testing.assert_allclose(k[:, :2], [[0.5, 0.5], [0.0, 0.0]], atol=1e-6)
    assert anchor == (0, 0) and k.sum() == pytest.approx(1.0)
    # Backwards and diagonal: sums to one, centroid half-way along the shift.
    for shift in ((-1.6, 0.0), (0.7, -1.3)):
        k, (ax, ay) = segment_kernel(shift)
        rows, cols = np.mgrid[0 : k.shape[0], 0 : k.shape[1]]
        assert k.sum() == pytest.approx(1.0, abs=1e-6)
        assert (k * (cols - ax)).sum() == pytest.approx(shift[0] / 2, abs=1e-3)
        assert (k * (rows - ay)).sum() == pytest.approx(shift[1] / 2, abs=1e-3)


def _segment_kernel_numpy(sx, sy, taps):
    """The box kernel as numpy computed it before it was compiled (the reference)."""
    t = np.linspace(0.0, 1.0, taps)
    px, py = t * sx, t * sy
    x0, y0 = np.floor(px), np.floor(py)
    ax, ay = px - x0, py - y0
    ox, oy = int(x0.min()), int(y0.min())
    kw, kh = int(x0.max()) - ox + 2, int(y0.max()) - oy + 2
    ix, iy = (x0 - ox).astype(np.intp), (y0 - oy).astype(np.intp)
    index = np.concatenate([iy * kw + ix, iy * kw + ix + 1, (iy + 1) * kw + ix, (iy + 1) * kw + ix + 1])
    weight = np.concatenate([(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay])
    kernel = (np.bincount(index, weight, minlength=kw * kh).reshape(kh, kw) / taps).astype(np.float32)
    return kernel, (-ox, -oy)


def test_segment_kernel_is_the_numpy_kernel_to_the_bit():
    rng = np.random.default_rng(0)
    for k in range(400):
        mag = float(rng.choice([0.01, 0.3, 1.0, 3.0, 30.0]))
        sx, sy = (round(float(v), 3) for v in rng.uniform(-mag, mag, 2))
        sy = 0.0 if k % 7 == 0 else sy
        ref, ref_anchor = _segment_kernel_numpy(sx, sy, 64)
        kernel, anchor = segment_kernel((sx, sy))
        assert anchor == ref_anchor and kernel.dtype == ref.dtype and np.array_equal(kernel, ref), (sx, sy)


def test_row_blur_is_row_blur_px_to_the_bit():
    # The renderer's per-camera RowBlur precomputes what does not depend on the travel.
    forward = np.array([np.nan, np.nan, 80.0, 30.0, 12.0, 6.0, 3.5, 2.1])
    rows = np.arange(len(forward), dtype=np.float64)
    rb = RowBlur(forward, horizon_row=1.3, half_width_px=160.0, first_ground_row=2)
    for travel in (0.0, 0.01, 0.14, 0.5, 3.0):
        ref = row_blur_px(forward, rows, horizon_row=1.3, half_width_px=160.0, travel_m=travel)
        start, length = rb(travel)
        assert np.array_equal(length, ref) and start == blur_start_row(ref, 2)


def test_texture_blur_averages_linear_light():
    # A black/white edge (texels 0-3 black, 4-7 white) blurred over 2 texels: texel g
    # averages x in [g, g + 2], bilinear between texels (a ramp on [3, 4]), in linear
    # light: texel 2 sees black on [2, 3] and the ramp, 0.25; texel 3 the ramp and
    # white, 0.75 (averaging the sRGB codes instead would give 0.52).
    rgba = np.zeros((8, 8, 4), np.uint8)
    rgba[:, 4:, :3] = 255
    out = box_blur_texture(rgba, (2.0, 0.0))
    lin = srgb_to_linear(np.ascontiguousarray(out[:, :, :3]))[4, :, 0]
    assert lin[2] == pytest.approx(0.25, abs=0.01) and lin[3] == pytest.approx(0.75, abs=0.01)
    assert lin[1] == pytest.approx(0.0, abs=1e-3) and lin[4] == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_texture_blur_is_opencvs_16_bit_filter_to_the_bit(seed):
    # box_blur_texture filters small kernels on float32 (OpenCV's vectorised path) and
    # rounds as OpenCV's 16-bit filter does: the same codes as filtering the 16-bit
    # linear values, for random, smooth and extreme textures and short to long shifts.
    rng = np.random.default_rng(seed)
    to_linear, to_srgb = _tables()
    for trial in range(60):
        mag = float(rng.choice([0.3, 1.0, 3.0, 8.0, 30.0]))
        shift = (float(rng.uniform(-mag, mag)), float(rng.uniform(-mag, mag)))
        h, w = (int(v) for v in rng.integers(3, 90, 2))
        rgba = [
            rng.integers(0, 256, (h, w, 4), dtype=np.uint8),
            np.clip(rng.normal(120, 30, (h, w, 4)), 0, 255).astype(np.uint8),
            rng.choice(np.array([0, 1, 254, 255], np.uint8), (h, w, 4)),
        ][trial % 3]
        kernel, anchor = segment_kernel(shift)
        ref16 = cv2.filter2D(cv2.LUT(rgba, to_linear), -1, kernel, anchor=anchor, borderType=cv2.BORDER_REPLICATE)
        ref = np.empty(rgba.shape, np.uint8)
        decode(ref16, to_srgb, ref)
        assert np.array_equal(box_blur_texture(rgba, shift), ref), (shift, kernel.shape)


def test_depth_plan_matches_the_scale_plan():
    cam = PinholeCamera(CameraConfig(width=64, height=48, hfov_deg=90.0, pitch_deg=0.0))
    f, cx = float(cam.K[0, 0]), float(cam.K[0, 2])
    img = np.random.default_rng(0).random((48, 64, 3), dtype=np.float32)
    depth = cam.depth.astype(np.float32)
    a, b = img.copy(), img.copy()
    radial_blur(a, motion_blur_scale(depth, focal_px=f, cx=cx, travel_m=0.3), cx, float(cam.horizon_row), 1.5)
    ids = np.arange(48 * 64, dtype=np.int32).reshape(48, 64)  # a face per pixel: all blurred
    radial_blur_depth(b, depth, ids, False, inv_cos_bearing(64, f, cx), 0.3, cx, float(cam.horizon_row), 1.5)
    np.testing.assert_allclose(a, b, atol=1e-5)
    assert not np.allclose(a, img)


@pytest.mark.parametrize("seed", [0, 1])
def test_flat_face_plan_with_near_edge_maps_is_the_plan_to_the_bit(seed):
    # Facades with windows and boxes in front, over the ground, at the frame's edges
    # too: the plan that skips the face test in boxes of one face (near-edge maps,
    # vectorised arithmetic) lists the same pixels with the same numbers.
    rng = np.random.default_rng(seed)
    h, w = 90, 160
    cam = PinholeCamera(CameraConfig(width=w, height=h))
    f, cx, foe = float(cam.K[0, 0]), float(cam.K[0, 2]), float(cam.horizon_row)
    ids = np.full((h, w), -1, np.int32)
    depth = cam.depth.astype(np.float32)
    for k in range(40):
        y0, x0 = int(rng.integers(-10, h)), int(rng.integers(-10, w))
        dy, dx = (int(v) for v in rng.integers(1, 40, 2))
        sl = (slice(max(y0, 0), max(y0 + dy, 0)), slice(max(x0, 0), max(x0 + dx, 0)))
        ids[sl] = k
        depth[sl] = rng.uniform(0.5, 60.0)
    near = near_edge_maps(ids)
    inv = inv_cos_bearing(w, f, cx)
    planned = 0
    for travel in (0.005, 0.05, 0.3, 2.0):
        args = (inv, np.float32(travel), np.float32(cx), np.float32(foe), np.float32(1.5))
        ref = _plan_depth(depth, ids, True, *args)
        got = _plan_flat(depth, ids, near[0], near[1], *args)
        n = int(ref[4][-1])
        assert np.array_equal(ref[4], got[4]) and ref[5] == got[5]
        for a, b in zip(ref[:4], got[:4]):
            assert np.array_equal(a[:n], b[:n]), travel
        planned += n
    assert planned > 1000


def test_sensor_leaves_the_ground_to_the_renderer_and_skips_flat_face_interiors():
    cam = PinholeCamera(CameraConfig(width=64, height=48, hfov_deg=90.0, pitch_deg=0.0))
    p = dataclasses.replace(SensorParams.none(), motion_blur=True, adc_bits=16)
    img = np.random.default_rng(1).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    still, _ = apply_sensor(img, p, cam, np.random.default_rng(0), speed_m_s=0.0)
    ground = np.full((48, 64), -1, np.int32)
    out, _ = apply_sensor(img, p, cam, np.random.default_rng(0), speed_m_s=30.0, face_id=ground)
    assert np.array_equal(out, still)  # all ground: the renderer's blur, nothing more
    with pytest.raises(SimroadError, match="face_id"):
        apply_sensor(img, p, cam, np.random.default_rng(0), speed_m_s=30.0, face_id=np.zeros((4, 4), np.int32))


def test_skipping_flat_face_interiors_is_as_exact_as_blurring_them():
    # Two flat-coloured faces (a bright box on a dark wall, below the horizon), against
    # the box average of 256 taps along each pixel's flow (cv2.remap, independent).
    import cv2

    cam = PinholeCamera(CameraConfig(width=64, height=48, hfov_deg=90.0, pitch_deg=0.0))
    f, cx, foe = float(cam.K[0, 0]), float(cam.K[0, 2]), float(cam.horizon_row)
    lin = np.full((48, 64, 3), 0.02, np.float32)
    ids = np.zeros((48, 64), np.int32)
    lin[30:44, 36:56] = 0.6
    ids[30:44, 36:56] = 1
    depth = cam.depth.astype(np.float32)
    travel = 0.4
    scale = motion_blur_scale(depth, focal_px=f, cx=cx, travel_m=travel)
    v, u = np.mgrid[0:48, 0:64].astype(np.float32)
    exact = np.zeros_like(lin)
    for t in np.linspace(0.0, 1.0, 256):
        mx = (u + t * scale * (u - cx)).astype(np.float32)
        my = (v + t * scale * (v - foe)).astype(np.float32)
        exact += cv2.remap(lin, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE) / 256
    inv = inv_cos_bearing(64, f, cx)
    skip, every = lin.copy(), lin.copy()
    radial_blur_depth(skip, depth, ids, True, inv, travel, cx, foe, 1.5)
    radial_blur_depth(every, depth, ids, False, inv, travel, cx, foe, 1.5)
    assert np.abs(exact - lin).max() > 0.2  # the box's edges smear
    err_skip, err_every = np.abs(skip - exact), np.abs(every - exact)
    assert err_skip.mean() <= err_every.mean() + 1e-4
    # The worst pixel (on an edge) is the doubling's own approximation (~0.09 of the
    # 0.58 step here in both); skipping shifts it by little.
    assert err_skip.max() <= err_every.max() + 0.02
    # Deep inside the box nothing moves in either.
    assert np.array_equal(skip[33:37, 40:46], lin[33:37, 40:46])


def test_cast_shadow_edges_smear_with_the_exposure_travel():
    from simroad.noise._occluders import N_VERT, Shadows
    from simroad.noise.shadow import rasterize_shadows

    cam = PinholeCamera(CameraConfig(width=320, height=180))
    cam.set_pose(0.0, 0.0, 0.0)
    square = np.array([[8.0, -2.0], [12.0, -2.0], [12.0, 2.0], [8.0, 2.0]])
    poly = np.vstack([square, np.repeat(square[-1:], N_VERT - 4, axis=0)])
    sh = Shadows(poly[None], np.array([0.02]), np.array([[8.0, -2.0, 12.0, 2.0]]), np.array([-1]))
    still = rasterize_shadows(sh, cam)
    moving = rasterize_shadows(sh, cam, motion_m=0.5)
    soft = lambda c: int(((c > 0.02) & (c < 0.98)).sum())  # noqa: E731
    assert soft(moving) > 2 * soft(still)  # the near and far edges smear along the view
    assert moving.sum() == pytest.approx(still.sum(), rel=0.05)  # the light is moved, not lost
