"""Shadow: sky-lit colour, world anchoring, order-free lazy placement beside the road."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from simroad.camera import ASPHALT, VehicleBox
from simroad.camera.lanes import lane_signed_distance
from simroad.noise import ShadowModel, ShadowParams, make_weather
from simroad.noise._occluders import prism_shadows
from simroad.noise.shadow import shadow_factor


def test_shadow_factor_by_hand_and_bluest_in_blue():
    k = shadow_factor((8.0, 6.0, 3.0), math.radians(30.0))
    np.testing.assert_allclose(k, [1 / 5, 1 / 4, 1 / 2.5])
    assert k[2] > k[1] > k[0]
    dimmed = shadow_factor((8.0, 6.0, 3.0), math.radians(30.0), sun_transmittance=0.1)
    assert (dimmed > k).all()  # a dimmed sun casts weaker shadows


def test_penumbra_grows_with_the_occluders_height():
    fp = [np.array([[0, 0], [0.2, 0], [0.2, 0.2], [0, 0.2]], float)] * 3
    z1 = np.array([2.0, 6.0, 12.0])
    sh = prism_shadows(fp, np.zeros(3), z1, (0.0, math.radians(40.0)), math.radians(0.53))
    np.testing.assert_allclose(sh.penumbra_m, z1 / math.sin(math.radians(40)) * math.tan(math.radians(0.53)))


def _hsv_stats(rgb: np.ndarray, sel: np.ndarray) -> tuple[float, float, float]:
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    px = rgb[sel].astype(float)
    return hsv[..., 2][sel].mean(), hsv[..., 1][sel].mean(), (px[:, 2] / np.maximum(px[:, 0], 1)).mean()


def test_shadowed_asphalt_is_darker_more_saturated_and_bluer(scene):
    # The sun low behind the car: the ego's own shadow falls on the road ahead.
    p = ShadowParams(sun_azimuth_deg=180.0, sun_elevation_deg=15.0, occluders_per_100m=0.0, vehicle_shadows=False)
    w = make_weather("shadow", severity=0.5, params={"shadow": p})
    w.reset(0, world=scene.world)
    out, masks = w.apply(scene.frame.rgb, scene.ctx())
    asphalt = scene.frame.material == ASPHALT
    shade, lit = asphalt & masks["shadow"], asphalt & ~masks["shadow"]
    assert shade.sum() > 500 and lit.sum() > 500
    v_s, s_s, br_s = _hsv_stats(out, shade)
    v_l, s_l, br_l = _hsv_stats(out, lit)
    assert v_s < v_l and s_s > s_l + 10 and br_s > 1.2 * br_l
    # The same pixels, lit (input) and in shadow (output):
    v_0, s_0, br_0 = _hsv_stats(scene.frame.rgb, shade)
    # (aged asphalt is warm, R/G ~ G/B ~ 1.2: the blue skylight first cancels that tint,
    # so the saturation gain over the lit input is smaller than over neutral grey)
    assert v_s < 0.75 * v_0 and s_s > s_0 + 5 and br_s > 1.2 * br_0


def test_shadows_stay_on_the_ground_while_the_car_moves(scene):
    p = ShadowParams(
        sun_elevation_deg=30.0, occluders_per_100m=40.0, overpasses_per_km=5.0, vehicle_shadows=False, ego_shadow=False
    )
    model = ShadowModel(p)
    model.reset(11, world=scene.world)
    views = []
    for pose in [(62.0, 0.0, 0.0), (70.0, 0.6, 0.06)]:
        renderer, cam = scene.renderer()
        frame = renderer.render(pose, [])
        _, masks = model.apply(
            frame.rgb, scene.ctx(camera=cam, depth=frame.depth, material=frame.material, vehicles=())
        )
        mask = masks["shadow"]
        near = np.isfinite(frame.depth) & (frame.depth < 50)
        views.append((cam.pose, mask & near, near))
    (pose_a, mask_a, near_a), (pose_b, mask_b, _) = views
    assert mask_a.sum() > 300 and mask_b.sum() > 300
    rows, cols = np.nonzero(mask_b)
    _, cam = scene.renderer()
    cam.set_pose(*pose_b)
    world_xy = cam.image_to_ground(np.column_stack([cols, rows]).astype(float))
    cam.set_pose(*pose_a)
    uv = np.rint(cam.ground_to_image(world_xy)).astype(int)
    h, w = mask_a.shape
    seen = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    uv = uv[seen]
    seen_by_a = near_a[uv[:, 1], uv[:, 0]]
    assert seen_by_a.sum() > 200
    grown = cv2.dilate(mask_a.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    agree = grown[uv[seen_by_a, 1], uv[seen_by_a, 0]]
    assert agree.mean() > 0.95


def test_cell_contents_do_not_depend_on_the_visiting_order(scene):
    p = ShadowParams(occluders_per_100m=30.0, overpasses_per_km=10.0)
    cells = [(i, j) for i in range(-1, 4) for j in range(-2, 1)]
    a, b = ShadowModel(p), ShadowModel(p)
    a.reset(5, world=scene.world)
    b.reset(5, world=scene.world)
    sa = {c: a.cell(*c) for c in cells}
    sb = {c: b.cell(*c) for c in reversed(cells)}
    assert sum(len(s.penumbra_m) for s in sa.values()) > 20
    for c in cells:
        np.testing.assert_array_equal(sa[c].polys, sb[c].polys)


def test_occluders_stand_beside_the_road_not_on_it(scene):
    m = ShadowModel(ShadowParams(occluders_per_100m=40.0))
    m.reset(2, world=scene.world)
    x0, y0, x1, y1 = scene.world.bounds()
    cell = m.params.cell_m
    shoulder = scene.world.palette.shoulder_width_m
    lanes = [s.lane for s in scene.world.shapes]
    kinds = []
    for i in range(math.floor(x0 / cell), math.floor(x1 / cell) + 1):
        for j in range(math.floor(y0 / cell), math.floor(y1 / cell) + 1):
            occ = m.occluders(i, j)
            for kind, fp in zip(occ.kinds, occ.footprints):
                kinds.append(kind)
                pts = fp if kind == "building" else fp.mean(axis=0, keepdims=True)
                for lane in lanes:
                    d = lane_signed_distance(lane, pts[:, 0], pts[:, 1])
                    assert (d <= -shoulder + 0.05).all(), (kind, pts)
    assert {"tree", "pole", "building"} <= set(kinds)


def test_vehicles_cast_shadows_that_move_with_them(scene):
    p = ShadowParams(sun_azimuth_deg=90.0, sun_elevation_deg=25.0, occluders_per_100m=0.0, ego_shadow=False)
    out = []
    for x in (95.0, 99.0):
        w = make_weather("shadow", severity=0.5, params={"shadow": p})
        w.reset(0, world=scene.world)
        car = VehicleBox(x, 4.5, 0.0, 5.0, 2.0, (20, 20, 200))
        renderer, cam = scene.renderer()
        frame = renderer.render(scene.pose, [car])
        out.append(
            w.apply(frame.rgb, scene.ctx(camera=cam, depth=frame.depth, material=frame.material, vehicles=[car]))[1][
                "shadow"
            ]
        )
    assert out[0].sum() > 20 and out[1].sum() > 20
    assert not np.array_equal(out[0], out[1])


@pytest.mark.parametrize("az", [0.0, 90.0, 200.0])
def test_shadow_and_glare_share_one_sun(az):
    from simroad.noise import GlareParams

    w = make_weather(
        "shadow+glare", severity=0.5, params={"glare": GlareParams(sun_azimuth_deg=az, sun_elevation_deg=12.0)}
    )
    w.reset(0)
    assert w.models["shadow"].sun == pytest.approx(w.models["glare"].sun)
    assert w.models["glare"].sun == pytest.approx((math.radians(az), math.radians(12.0)))
