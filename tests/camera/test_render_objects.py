"""The renderer draws scenery and vehicles over the ground: truth maps and contact shadows."""

from __future__ import annotations

import numpy as np
from highway_env.road.lane import LineType, StraightLane
from highway_env.road.road import RoadNetwork

from simroad.camera import CameraConfig, CameraRenderer, Frame, PinholeCamera, VehicleBox, WorldRaster
from simroad.camera.codes import BUILDING, IS_ROAD
from simroad.camera.mesh import Mesh
from simroad.camera.vehicles import box_mesh
from simroad.envs import RoadCamEnv
from simroad.experiments.rollout import autopilot_env_action

POSE = (20.0, 0.0, 0.0)


class _Scenery:
    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh

    def meshes(self, xmin, ymin, xmax, ymax) -> Mesh:
        return self.mesh


def _renderer(seed=0, scenery: Mesh | None = None, size=(320, 180)) -> CameraRenderer:
    net = RoadNetwork()
    line = (LineType.CONTINUOUS, LineType.STRIPED)
    for k in range(2):
        net.add_lane("a", "b", StraightLane([0, 4.0 * k], [300, 4.0 * k], width=4.0, line_types=line))
    rng = np.random.default_rng(seed)
    world = WorldRaster(net, rng)
    if scenery is not None:
        world.scenery = _Scenery(scenery)
    cam = PinholeCamera(CameraConfig(width=size[0], height=size[1]))
    return CameraRenderer(cam, world, rng)


def _car(x, y=0.0):
    return VehicleBox(x, y, 0.0, 5.0, 2.0, (180, 180, 180), paint=(0.4, 0.4, 0.4))


def test_frame_keeps_its_constructor_and_defaults_face_id():
    f = Frame(np.zeros((4, 5, 3), np.uint8), np.zeros((4, 5), np.uint8), np.zeros((4, 5), bool), np.zeros((4, 5)))
    assert f.face_id.shape == (4, 5) and f.face_id.dtype == np.int32 and np.all(f.face_id == -1)
    assert len(f.faces) == 0 and f.vehicles == []


def test_road_mask_is_the_visible_road_only():
    bare = _renderer().render(POSE)
    frame = _renderer().render(POSE, [_car(35.0), _car(60.0, 4.0)])
    covered = frame.face_id >= 0
    assert covered.sum() > 300
    assert not (frame.road_mask & covered).any()
    assert (bare.road_mask & covered).sum() > 100  # the cars stand on road
    np.testing.assert_array_equal(frame.road_mask[~covered], bare.road_mask[~covered])
    np.testing.assert_array_equal(frame.road_mask, bare.road_mask & ~covered)
    assert not IS_ROAD[frame.material[covered]].any()
    assert np.all(frame.faces.material[frame.face_id[covered]] == frame.material[covered])


def test_scenery_from_the_world_is_drawn_and_hides_the_road():
    building = box_mesh(60.0, 2.0, 0.0, 10.0, 30.0, 0.0, 12.0, albedo=(0.3, 0.3, 0.3), material=BUILDING)
    frame = _renderer(scenery=building).render(POSE, [_car(35.0)])
    assert (frame.material == BUILDING).sum() > 500
    assert not (frame.road_mask & (frame.material == BUILDING)).any()
    assert np.all(np.isfinite(frame.depth[frame.material == BUILDING]))
    d = frame.depth[frame.material == BUILDING]
    assert d.min() >= 60.0 - 5.0 - 0.8 - 20.0 - 1e-3 - 1.0 and d.max() < 80.0


def test_contact_shadow_darkens_the_ground_beside_a_car_but_not_two_metres_away():
    r = _renderer()
    bare = r.render(POSE)
    r2 = _renderer()
    car = _car(30.0, 2.0)
    frame = r2.render(POSE, [car])
    cam = r2.camera
    ground = cam.ground_valid & (frame.face_id < 0)
    eg = cam.ego_ground  # (H, W, 2), from the ego centre
    # Ego at x = 20, heading +x: the car's centre is at ego (10, 2).
    dx, dy = np.abs(eg[..., 0] - 10.0) - 2.5, np.abs(eg[..., 1] - 2.0) - 1.0
    sd = np.hypot(np.maximum(dx, 0), np.maximum(dy, 0)) + np.minimum(np.maximum(dx, dy), 0)
    near = ground & (sd > 0.02) & (sd < 0.15)
    far = ground & (sd > 2.0)
    assert near.sum() > 10
    lum_bare = bare.rgb.astype(float).sum(axis=2)
    lum = frame.rgb.astype(float).sum(axis=2)
    assert np.mean(lum[near] / np.maximum(lum_bare[near], 1)) < 0.88
    np.testing.assert_array_equal(frame.rgb[far], bare.rgb[far])
    np.testing.assert_array_equal(frame.material[ground], bare.material[ground])
    np.testing.assert_array_equal(frame.road_mask[ground], bare.road_mask[ground])


def test_same_seed_same_frame_with_objects():
    a = _renderer(3).render(POSE, [_car(35.0), _car(50.0, 4.0)])
    b = _renderer(3).render(POSE, [_car(35.0), _car(50.0, 4.0)])
    for x, y in ((a.rgb, b.rgb), (a.material, b.material), (a.depth, b.depth), (a.face_id, b.face_id)):
        np.testing.assert_array_equal(x, y)


def test_env_vehicle_colours_are_stable_and_from_the_paint_table():
    env = RoadCamEnv(scenario="highway", traffic=True)
    env.reset(seed=4)
    first = {id(v): env._box(v).paint for v in env.highway_env.road.vehicles if v is not env.vehicle}
    for _ in range(3):
        env.step(autopilot_env_action(env))
    again = {id(v): env._box(v).paint for v in env.highway_env.road.vehicles if v is not env.vehicle}
    assert first and all(again[k] == p for k, p in first.items() if k in again)
    assert all(p is not None for p in first.values())
    env.close()
