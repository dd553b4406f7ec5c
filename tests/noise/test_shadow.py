"""Shadow: sky-lit colour, world anchoring, the severity sets the sun, faces shaded by it."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from simroad.camera import ASPHALT, VehicleBox
from simroad.camera.codes import BUILDING, IS_GROUND
from simroad.camera.mesh import Mesh
from simroad.camera.scenery import Scenery
from simroad.errors import SimroadError
from simroad.noise import ShadowModel, ShadowParams, make_weather
from simroad.noise._occluders import prism_shadows
from simroad.noise.shadow import FULL_SUN_SKY_RATIO, face_sun_factor, shadow_factor


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
    p = ShadowParams(sun_azimuth_deg=180.0, sun_elevation_deg=15.0, vehicle_shadows=False)
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
    # so the saturation gain over the lit input is smaller than over neutral grey; the
    # camera's tone curve, display ~ linear ** (CAMERA_TONE_GAMMA / GAMMA) = 0.73, shows
    # shade at 0.7 of the lit irradiance as 0.77 of its value)
    assert v_s < 0.8 * v_0 and s_s > s_0 + 5 and br_s > 1.2 * br_0


@pytest.fixture
def scenery(scene):
    """The sample scene's world with dense scenery (detached again afterwards)."""
    scene.world.scenery = Scenery(scene.world.shapes, 11, density=4.0, shoulder_m=scene.world.palette.shoulder_width_m)
    yield scene
    scene.world.scenery = None


def test_shadows_stay_on_the_ground_while_the_car_moves(scenery):
    scene = scenery
    p = ShadowParams(sun_elevation_deg=30.0, vehicle_shadows=False, ego_shadow=False)
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
        near = IS_GROUND[frame.material] & (frame.depth < 50)  # ground only: objects' faces are not on it
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


def test_severity_sets_the_sun_and_zero_is_the_identity(scene):
    p0, p1 = ShadowParams.from_severity(0.0), ShadowParams.from_severity(1.0)
    assert p0.is_identity and not p1.is_identity
    assert p1.sun_elevation_deg == pytest.approx(20.0) and p1.sun_sky_ratio_rgb == pytest.approx(FULL_SUN_SKY_RATIO)
    half = ShadowParams.from_severity(0.5)
    assert half.sun_elevation_deg == pytest.approx(40.0)
    assert half.sun_sky_ratio_rgb == pytest.approx(tuple(0.5 * c for c in FULL_SUN_SKY_RATIO))
    w = make_weather("shadow", severity=0.0)
    w.reset(0, world=scene.world)
    out, masks = w.apply(scene.frame.rgb, scene.ctx())
    np.testing.assert_array_equal(out, scene.frame.rgb)
    assert not masks["shadow"].any()


@pytest.mark.parametrize("gone", ["occluders_per_100m", "overpasses_per_km", "cell_m"])
def test_the_caster_density_is_no_longer_a_shadow_parameter(gone):
    with pytest.raises(TypeError, match=gone):
        ShadowParams(**{gone: 1.0})


def test_without_scenery_only_vehicles_and_the_ego_cast(scene):
    p = ShadowParams(sun_azimuth_deg=180.0, sun_elevation_deg=15.0, vehicle_shadows=False, ego_shadow=False)
    w = make_weather("shadow", params={"shadow": p})
    w.reset(0, world=scene.world)
    _, masks = w.apply(scene.frame.rgb, scene.ctx())
    assert not masks["shadow"].any()


def test_face_shading_by_hand():
    # Sun from world +x at 30 degrees; a wall facing +x, one facing -x, a roof.
    sun = (0.0, math.radians(30.0))
    normals = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 0, 1.0]])
    f = face_sun_factor(normals, sun, (8.0, 6.0, 3.0))
    k = shadow_factor((8.0, 6.0, 3.0), sun[1])
    np.testing.assert_allclose(f[1], k, rtol=1e-6)  # turned away: its own shadow, the ground's factor
    np.testing.assert_allclose(f[2], 1.0, rtol=1e-6)  # a roof is lit like the ground
    sky = 0.5 + 0.15 * 0.5  # face_irradiance of a vertical face
    np.testing.assert_allclose(f[0], (np.array([8.0, 6.0, 3.0]) * math.cos(sun[1]) / sky + 1) * k, rtol=1e-5)
    assert (f[0] > 1).all()


def _square_face(x: float, normal_x: float) -> Mesh:
    v = np.zeros((1, 16, 3))
    v[0, :4] = [[x, -1, 0], [x, 1, 0], [x, 1, 2], [x, -1, 2]]
    v[0, 4:] = v[0, 3]
    return Mesh(v, np.array([4], np.int32), np.full((1, 3), 0.3, np.float32), np.array([12], np.uint8),
                np.array([[normal_x, 0.0, 0.0]]), np.zeros(1, np.int64))  # fmt: skip


@pytest.mark.parametrize("normal_x", [1.0, -1.0])
def test_object_faces_are_shaded_by_their_orientation(scene, normal_x):
    faces = Mesh.concat([_square_face(10.0, normal_x)])
    face_id = np.full(scene.frame.material.shape, -1, dtype=np.int32)
    face_id[10:30, 100:140] = 0  # a patch of the sky standing for the face
    patch = face_id == 0
    material = scene.frame.material.copy()
    material[patch] = BUILDING
    image = scene.frame.rgb.copy()
    image[patch] = 90  # a mid-grey facade: room to brighten and to darken
    p = ShadowParams(sun_azimuth_deg=0.0, sun_elevation_deg=30.0, vehicle_shadows=False, ego_shadow=False)
    w = make_weather("shadow", params={"shadow": p})
    w.reset(0, world=scene.world)
    plain, _ = w.apply(image, scene.ctx(material=material))
    out, masks = w.apply(image, scene.ctx(material=material, face_id=face_id, faces=faces))
    before, after = image[patch].astype(float), out[patch].astype(float)
    assert masks["shadow"][patch].all()
    assert (after.mean() > before.mean()) == (normal_x > 0)
    np.testing.assert_array_equal(out[~patch], plain[~patch])


def test_face_id_and_faces_are_checked(scene):
    faces = Mesh.concat([_square_face(10.0, 1.0)])
    bad = np.full(scene.frame.material.shape, 3, dtype=np.int32)
    with pytest.raises(SimroadError, match="face_id"):
        scene.ctx(face_id=bad, faces=faces)
    with pytest.raises(SimroadError, match="faces"):
        scene.ctx(face_id=np.zeros(scene.frame.material.shape, np.int32))
    with pytest.raises(SimroadError, match="face_id"):
        scene.ctx(face_id=np.zeros(scene.frame.material.shape, np.float32), faces=faces)


def test_vehicles_cast_shadows_that_move_with_them(scene):
    p = ShadowParams(sun_azimuth_deg=90.0, sun_elevation_deg=25.0, ego_shadow=False)
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
