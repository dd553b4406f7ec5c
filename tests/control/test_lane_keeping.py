"""Mask-driven lane keeping: run picking, path reading against the true lane, and
closed-loop driving on the real highway-env with the ground-truth mask."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.control import autopilot_action
from simroad.control.config import ControllerConfig
from simroad.control.drivers import make_driver
from simroad.control.lane_estimate import _occlusion_free, _pick_run
from simroad.control.lane_keeping import MaskLaneKeeper, _grip_speed
from simroad.envs import RoadCamEnv, get_scenario


def test_pick_run_contains_expected_position_and_bridges_slivers():
    y = np.linspace(-10, 10, 201)  # 0.1 m per column
    row = (np.abs(y) < 6) & ~((y > 1.95) & (y < 2.25))  # a 0.3 m sliver at y = 2.1
    row |= y > 8.0  # another road far right
    a, b = _pick_run(row, y, expect_y=0.0)
    assert y[a] == pytest.approx(-5.9) and y[b] == pytest.approx(5.9)  # sliver bridged
    assert _pick_run(row, y, expect_y=9.0)[0] == int(np.argmax(y > 8.0))
    assert _pick_run(np.zeros(201, bool), y, 0.0) is None


def test_occlusion_free_drops_a_car_side_but_follows_curves_and_reappearing_edges():
    x = np.array([5.0, 6, 7, 9, 11, 13, 15, 18, 21, 25])
    bend = np.array([-0.02, 0.0, 0.0])  # the previous path: a curve to the left, y = -0.02 x^2
    right = 2.0 - 0.02 * x**2  # the right edge follows it (2 m right of the path)
    assert np.array_equal(_occlusion_free(x, right, -1.0, bend), right)  # a curve is not a car
    hidden = right.copy()
    hidden[x >= 15] -= 2.5  # a car's side, 2.5 m inside the edge from 15 m on
    out = _occlusion_free(x, hidden, -1.0, bend)
    assert np.array_equal(out[x < 15], right[x < 15]) and np.isnan(out[x >= 15]).all()
    # Without a previous path: straight continuation; the same for the left edge (+1).
    left = np.full(len(x), -6.0)
    left[(x >= 9) & (x <= 13)] = -3.0  # a car on the left, then the edge again
    out = _occlusion_free(x, left, 1.0, None)
    assert np.isnan(out[(x >= 9) & (x <= 13)]).all() and (out[x > 13] == -6.0).all()
    # An edge that reappears farther out (the near rows were hidden) is kept.
    late = np.where(x < 9, 1.0, 3.0)
    assert np.array_equal(_occlusion_free(x, late, -1.0, None), late)


def test_controller_brakes_for_a_car_in_its_corridor_not_beside_it():
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    _, info = env.reset(seed=0)
    ego_x, ego_y = env.camera.ego_ground[..., 0], env.camera.ego_ground[..., 1]
    ahead = (ego_x > 14.0) & (ego_x < 18.0)
    cfg = ControllerConfig(lane_width_m=4.0, target_speed_m_s=25.0)
    clear = MaskLaneKeeper(env.camera, cfg).read_path(info["road_mask"])
    assert clear.free_road_m > 40.0
    for lateral, blocked in ((0.0, True), (4.0, False), (-4.0, False)):  # own lane, right, left
        mask = info["road_mask"] & ~(ahead & (np.abs(ego_y - lateral) < 0.9))
        ctl = MaskLaneKeeper(env.camera, cfg)
        est = ctl.read_path(mask)
        if blocked:
            assert 10.0 <= est.free_road_m < 14.0
            assert ctl.act(mask, 25.0)[1] < -0.5
        else:
            assert est.free_road_m > 40.0


def test_a_misread_frame_is_held_off_then_the_road_is_reacquired():
    """The gate: a mask whose road lies 4.5 m farther left is not the lane -- the previous
    path is held (and the car brakes) for ``coast_frames`` frames; a road that really
    moved is taken from the mask alone after that, and good frames lock on again."""
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    _, info = env.reset(seed=0)
    ego_y = env.camera.ego_ground[..., 1]
    good = info["road_mask"]
    cfg = ControllerConfig(lane_width_m=4.0, target_speed_m_s=25.0, coast_frames=2)
    ctl = MaskLaneKeeper(env.camera, cfg)
    centre = float(np.polyval(ctl.read_path(good).coeffs, 10.0))
    ctl.estimator.remember(ctl.estimator.read_path(good))
    off = env.camera.ground_valid & (ego_y > -10.5) & (ego_y < -2.5)  # the road 4.5 m farther left
    for frame in range(2):  # held: the old path, no free road
        action = ctl.act(off, 25.0)
        assert len(ctl.last.x_m) == 0 and ctl.last.free_road_m == 0.0, frame
        assert abs(np.polyval(ctl.last.coeffs, 10.0) - centre) < 1e-9 and action[1] < -0.5
    ctl.act(off, 25.0)  # the third frame in a row: the road moved, take it
    assert len(ctl.last.x_m) >= 3 and np.polyval(ctl.last.coeffs, 10.0) < centre - 3.0
    ctl.reset()
    ctl.act(good, 25.0)
    ctl.act(off, 25.0)  # one misread frame between good ones changes nothing
    ctl.act(good, 25.0)
    assert len(ctl.last.x_m) >= 3 and abs(np.polyval(ctl.last.coeffs, 10.0) - centre) < 0.2


def test_read_path_matches_the_true_lane_centre_on_a_curve():
    env = RoadCamEnv(scenario="winding", longitudinal=True, traffic=False)
    _obs, info = env.reset(seed=4)
    for _ in range(25):
        _obs, _, _, _, info = env.step(
            np.array([autopilot_action(env.highway_env.road, env.vehicle), 0.0], dtype=np.float32)
        )
    ctl = MaskLaneKeeper(env.camera, ControllerConfig.for_scenario(get_scenario("winding")))
    est = ctl.read_path(info["road_mask"])
    assert len(est.x_m) >= 5
    v = env.vehicle
    h = float(v.heading)
    net = env.highway_env.road.network
    errs = []
    for x, y in zip(est.x_m, est.centre_y_m):
        world = (
            np.asarray(v.position)
            + x * np.array([math.cos(h), math.sin(h)])
            + y * np.array([-math.sin(h), math.cos(h)])
        )
        lane = net.get_lane(net.get_closest_lane_index(world, h))
        errs.append(abs(lane.local_coordinates(world)[1]))
    assert np.median(errs) < 0.15 and max(errs) < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("scenario, seed, steps", [("winding", 1, 150), ("highway", 0, 60)])
def test_oracle_keeps_its_lane(scenario, seed, steps):
    env = RoadCamEnv(scenario=scenario, longitudinal=True, traffic=False)
    obs, info = env.reset(seed=seed)
    driver = make_driver("oracle", env)
    lats = []
    for _ in range(steps):
        obs, _, terminated, _, info = env.step(driver(obs, info))
        lats.append(info["lateral_offset_m"])
        assert info["offroad_distance_m"] == 0.0 and not terminated
    assert math.sqrt(np.mean(np.square(lats))) < 0.3
    assert info["speed_m_s"] > 0.8 * get_scenario(scenario).cruise_speed_m_s


def test_controller_slows_down_when_the_road_ends():
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    env.reset(seed=0)
    ctl = MaskLaneKeeper(env.camera, ControllerConfig(lane_width_m=4.0, target_speed_m_s=25.0))
    full = np.zeros((180, 320), bool)
    full[env.camera.ground_valid] = True
    short = full & (env.camera.depth < 15.0)
    assert ctl.act(full, 25.0)[1] >= 0.0
    ctl.reset()
    assert ctl.act(short, 25.0)[1] < -0.5


def test_bad_inputs():
    env = RoadCamEnv(scenario="racetrack", longitudinal=True)
    env.reset(seed=0)
    ctl = MaskLaneKeeper(env.camera)
    with pytest.raises(SimroadError, match="mask"):
        ctl.act(np.zeros((10, 10), bool), 5.0)
    with pytest.raises(SimroadError, match="driver"):
        make_driver("pilot", env)
    with pytest.raises(SimroadError, match="longitudinal"):
        make_driver("oracle", RoadCamEnv(scenario="racetrack"))
    with pytest.raises(SimroadError, match="lane_width_m"):
        ControllerConfig(lane_width_m=-1)


def test_controller_plans_within_its_grip():
    # On a road that ends 15 m ahead it brakes as hard as it dares: 4 m/s^2 on a dry
    # road (its own limit, below 0.6 * 0.8 g = 4.7), 0.6 * 0.1 g = 0.59 m/s^2 on ice.
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    env.reset(seed=0)
    full = np.zeros((180, 320), bool)
    full[env.camera.ground_valid] = True
    short = full & (env.camera.depth < 15.0)
    cfg = ControllerConfig(lane_width_m=4.0, target_speed_m_s=25.0)
    for mu, decel in ((None, 4.0), (0.8, 4.0), (0.1, 0.6 * 0.1 * 9.81)):
        ctl = MaskLaneKeeper(env.camera, cfg)
        assert ctl.act(short, 25.0, mu=mu)[1] * 5.0 == pytest.approx(-decel, rel=1e-5)
    with pytest.raises(SimroadError, match="mu"):
        MaskLaneKeeper(env.camera, cfg).act(full, 25.0, mu=0.0)


@pytest.mark.xfail(
    strict=True,
    reason="the path fit takes the far rows' run (another part of the track at the horizon): it reads "
    "this bend as R ~ 100 m, not 15-20 m (the lane keeper's path reading; start speeds, issue 32, do not "
    "touch it: on ice the oracle slid for a step in 1 of 6 racetrack worlds)",
)
def test_controller_slows_for_the_curve_it_sees_on_a_slippery_road():
    env = RoadCamEnv(scenario="racetrack", longitudinal=True, traffic=False)
    _, info = env.reset(seed=0)
    for _ in range(8):  # into the first bend
        _, _, _, _, info = env.step([autopilot_action(env.highway_env.road, env.vehicle), 0.0])
    ctl = MaskLaneKeeper(env.camera, ControllerConfig.for_scenario(get_scenario("racetrack")))
    est = ctl.read_path(info["road_mask"])
    rear = np.array([-ctl.config.wheelbase_m / 2.0, 0.0])
    dry, ice = (_grip_speed(est, rear, 0.6 * mu * 9.81) for mu in (0.8, 0.1))
    assert dry == pytest.approx(math.sqrt(8.0) * ice)  # v = sqrt(a / kappa)
    assert ice < 6.0 < dry < 15.0  # the bend's radius: 15-20 m
    assert _grip_speed(est, rear, math.inf) == math.inf  # no grip limit without mu
    assert ctl.act(info["road_mask"], 7.0, mu=0.1)[1] < 0.0 < ctl.act(info["road_mask"], 3.0, mu=0.1)[1]
