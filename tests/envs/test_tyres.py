"""The friction circle in highway-env's own vehicles: braking, cornering, traffic, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from highway_env.road.lane import CircularLane, StraightLane
from highway_env.road.road import Road, RoadNetwork
from highway_env.vehicle.behavior import IDMVehicle
from highway_env.vehicle.kinematics import Vehicle

from simroad.control.autopilot import STEERING_RANGE_RAD, autopilot_action
from simroad.core.constants import GRAVITY_M_S2 as G
from simroad.envs import RoadCamEnv
from simroad.envs.friction import RoadGrip, cornering_speed_m_s, stopping_distance_m
from simroad.envs.tyres import GripIDMVehicle, GripVehicle, attach_grip, grip_class
from simroad.errors import SimroadError

DT = 1.0 / 15.0  # highway-env's physics step in every scenario
MUS = (0.1, 0.25, 0.3, 0.5, 0.8)


def _road(*lanes) -> Road:
    net = RoadNetwork()
    for a, b, lane in lanes:
        net.add_lane(a, b, lane)
    return Road(network=net, np_random=np.random.default_rng(0))


def _brake_distance(mu: float, speed: float = 25.0) -> float:
    road = _road(("a", "b", StraightLane([0.0, 0.0], [2000.0, 0.0])))
    car = Vehicle(road, [0.0, 0.0], 0.0, speed)
    road.vehicles.append(car)
    attach_grip(road, RoadGrip(mu))
    car.act({"steering": 0.0, "acceleration": -100.0})  # full demand: more than any tyre delivers
    for _ in range(10_000):
        if car.speed <= 0.0:
            break
        car.step(DT)
    assert car.speed == 0.0  # stopped, not reversing
    return float(car.position[0])


@pytest.mark.parametrize("mu", MUS)
def test_braking_from_25_m_s_stops_within_theory(mu):
    theory = stopping_distance_m(25.0, mu)
    assert _brake_distance(mu) == pytest.approx(theory, rel=0.05)


def _circle(mu: float, speed: float, radius: float = 50.0, seconds: float = 8.0) -> tuple[float, int]:
    """Max |lateral offset| (m) and sliding steps of a car held at ``speed`` on a
    circular lane, steered by pure pursuit onto the lane centre."""
    lane = CircularLane([0.0, 0.0], radius, -math.pi / 2, 1.5 * math.pi, clockwise=True, width=3.5)
    road = _road(("a", "b", lane))
    car = Vehicle(road, lane.position(0.0, 0.0), lane.heading_at(0.0), speed)
    road.vehicles.append(car)
    attach_grip(road, RoadGrip(mu))
    car.speed = speed  # the friction circle under test, not the start speed attach_grip sets
    worst = 0.0
    for k in range(int(seconds / DT)):
        if k % 3 == 0:  # the policy rate: 5 Hz
            car.act({"steering": autopilot_action(road, car) * STEERING_RANGE_RAD, "acceleration": 0.0})
        car.step(DT)
        worst = max(worst, abs(lane.local_coordinates(car.position)[1]))
    return worst, car.slides


@pytest.mark.parametrize("mu", (0.3, 0.8))
def test_circle_held_below_the_cornering_speed_and_left_above(mu):
    limit = cornering_speed_m_s(mu, 50.0)
    held, slides = _circle(mu, 0.95 * limit)
    assert held < 0.5 and slides == 0
    out, slides = _circle(mu, 1.05 * limit)
    assert out > 3.5 / 2 and slides > 0  # understeer: a wider curve, out of the lane


def test_understeer_curvature_worked_by_hand():
    # 20 m/s steered onto a 50 m radius: 8 m/s^2 asked, mu 0.5 gives 4.905:
    # the path curvature falls from 1/50 to 4.905/400 = 0.01226 /m (an 81.5 m radius).
    road = _road(("a", "b", StraightLane([0.0, 0.0], [500.0, 0.0])))
    car = Vehicle(road, [0.0, 0.0], 0.0, 20.0)
    road.vehicles.append(car)
    attach_grip(road, RoadGrip(0.5))
    beta = math.asin(car.LENGTH / 2 / 50.0)  # kinematic bicycle: kappa = 2 sin(beta) / L
    car.act({"steering": math.atan(2 * math.tan(beta)), "acceleration": 0.0})
    car.step(DT)
    assert car.sliding
    assert car.heading / (20.0 * DT) == pytest.approx(0.5 * G / 20.0**2, rel=1e-6)
    assert car.speed == 20.0


def test_idm_traffic_brakes_within_its_grip():
    road = _road(("a", "b", StraightLane([0.0, 0.0], [3000.0, 0.0])))
    idm = IDMVehicle(road, [0.0, 0.0], 0.0, 20.0, target_speed=20.0)
    wall = Vehicle(road, [400.0, 0.0], 0.0, 0.0)  # 20 m/s stops in 204 m on ice
    road.vehicles += [idm, wall]
    attach_grip(road, RoadGrip(0.1))
    assert isinstance(idm, GripIDMVehicle) and idm.COMFORT_ACC_MIN == IDMVehicle.COMFORT_ACC_MIN
    decel = []
    for _ in range(int(40 / DT)):
        road.act()
        before = idm.speed
        road.step(DT)
        decel.append((before - idm.speed) / DT)
    assert max(decel) <= 0.1 * G + 1e-9
    assert idm.COMFORT_ACC_MIN == pytest.approx(-GripIDMVehicle.BRAKE_USE * 0.1 * G)  # plans with part of its grip
    assert not idm.crashed and idm.speed < 0.5


def test_idm_traffic_slows_for_the_curve_ahead():
    straight = StraightLane([0.0, 0.0], [150.0, 0.0], width=3.5)
    curve = CircularLane([150.0, 30.0], 30.0, -math.pi / 2, 0.0, clockwise=True, width=3.5)
    road = _road(("a", "b", straight), ("b", "c", curve))
    idm = IDMVehicle(road, [0.0, 0.0], 0.0, 15.0, target_speed=15.0)
    road.vehicles.append(idm)
    attach_grip(road, RoadGrip(0.25))  # the curve holds sqrt(0.25 g 30) = 8.6 m/s
    worst = 0.0
    for _ in range(int(20 / DT)):
        road.act()
        road.step(DT)
        if idm.lane_index[:2] == ("b", "c"):
            worst = max(worst, abs(curve.local_coordinates(idm.position)[1]))
    assert idm.slides == 0 and worst < 0.5
    assert idm.lane_index[:2] == ("b", "c")  # it got there


def test_grip_classes_keep_state_and_refuse_non_vehicles():
    assert grip_class(Vehicle) is GripVehicle and grip_class(GripVehicle) is GripVehicle

    class Mine(IDMVehicle):
        pass

    made = grip_class(Mine)
    assert issubclass(made, GripIDMVehicle) and issubclass(made, Mine) and grip_class(Mine) is made
    with pytest.raises(SimroadError, match="cls"):
        grip_class(int)
    with pytest.raises(SimroadError, match="grip"):
        attach_grip(_road(("a", "b", StraightLane([0, 0], [10, 0]))), 0.5)


def _rollout(seed: int, steps: int = 12, **options) -> list[np.ndarray]:
    env = RoadCamEnv(width=64, height=48, camera_effects=False, scenery=0.0, **options)
    env.reset(seed=seed)
    poses = []
    for _ in range(steps):
        _, _, term, trunc, _ = env.step([autopilot_action(env.highway_env.road, env.vehicle)])
        poses.append(np.array([[*v.position, v.heading, v.speed] for v in env.highway_env.road.vehicles]))
        if term or trunc:
            break
    env.close()
    return poses


def test_same_seed_same_trajectories_on_snow_patches():
    from simroad.noise import SnowParams

    opts = {"scenario": "winding", "noise": "snow", "severity": 1.0}
    opts["noise_params"] = {"snow": SnowParams(settle=0.7, settle_on_road=True, flake_density_m3=100.0)}
    a, b = _rollout(3, **opts), _rollout(3, **opts)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_env_reports_mu_and_sliding_and_friction_off_is_highway_env():
    env = RoadCamEnv(scenario="winding", width=64, height=48, road_surface="ice", camera_effects=False)
    _, info = env.reset(seed=0)
    assert info["mu"] == 0.1 and info["sliding"] is False
    assert all(isinstance(v, GripVehicle) for v in env.highway_env.road.vehicles)
    _, _, _, _, info = env.step([1.0])  # full lock at 15 m/s on ice
    assert info["sliding"] is True
    env = RoadCamEnv(scenario="winding", width=64, height=48, friction=False, camera_effects=False)
    _, info = env.reset(seed=0)
    assert info["mu"] is None and info["sliding"] is False
    assert not any(isinstance(v, GripVehicle) for v in env.highway_env.road.vehicles)
