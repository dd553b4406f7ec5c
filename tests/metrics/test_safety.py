"""Safety metrics against cases worked by hand, on real highway-env objects."""

from __future__ import annotations

import math

import numpy as np
import pytest
from highway_env.road.lane import StraightLane
from highway_env.road.road import Road, RoadNetwork
from highway_env.vehicle.kinematics import Vehicle

from simroad.metrics.safety import PENALTIES, SafetyScore, footprint_corners


def _road(vehicles_at):
    net = RoadNetwork()
    net.add_lane("a", "b", StraightLane([0, 0], [500, 0], width=4.0))
    road = Road(net, np_random=np.random.default_rng(0))
    vs = []
    for x, y, speed in vehicles_at:
        v = Vehicle(road, [x, y], 0.0, speed)
        road.vehicles.append(v)
        vs.append(v)
    return road, vs


def _info(lat=0.0, herr=0.0):
    return {"lateral_offset_m": lat, "heading_error_rad": herr}


def test_footprint_corners_by_hand():
    _, (v,) = _road([(10.0, 0.0, 0.0)])
    v.heading = math.pi / 2  # pointing +y
    c = footprint_corners(v)
    np.testing.assert_allclose(c, [[11.0, 2.5], [9.0, 2.5], [9.0, -2.5], [11.0, -2.5]], atol=1e-12)


def test_offroad_when_a_corner_leaves_the_road():
    road, (v,) = _road([(50.0, 0.0, 10.0)])
    s = SafetyScore(dt=0.2, route_length_m=100.0)
    s.update(road, v, _info())
    assert s.offroad_steps == 0 and s.lane_departures == 0
    v.position = np.array([50.0, 1.2])  # corner at y = 2.2 > 2.0
    s.update(road, v, _info(1.2))
    s.update(road, v, _info(1.2))
    v.position = np.array([50.0, 0.0])
    s.update(road, v, _info())
    r = s.result()
    assert r["offroad_steps"] == 2 and s.offroad_events == 1 and r["lane_departures"] == 1
    assert r["offroad_fraction"] == pytest.approx(0.5)
    assert r["lateral_max_m"] == pytest.approx(1.2)
    assert r["lateral_rmse_m"] == pytest.approx(math.sqrt(2 * 1.44 / 4))


def test_a_car_across_two_lanes_is_on_the_road_and_off_it_past_the_outer_edge():
    net = RoadNetwork()
    net.add_lane("a", "b", StraightLane([0, 0], [500, 0], width=4.0))  # y in [-2, 2]
    net.add_lane("a", "b", StraightLane([0, 4], [500, 4], width=4.0))  # y in [2, 6]
    road = Road(net, np_random=np.random.default_rng(0))
    v = Vehicle(road, [50.0, 2.0], 0.0, 10.0)  # on the shared edge: corners in both lanes
    road.vehicles.append(v)
    s = SafetyScore(dt=0.2, route_length_m=100.0)
    s.update(road, v, _info())
    assert s.offroad_steps == 0
    v.position = np.array([50.0, 5.2])  # the outer corners at y = 6.2 > 6
    s.update(road, v, _info())
    v.position = np.array([50.0, -1.2])  # the outer corners at y = -2.2 < -2
    s.update(road, v, _info())
    assert s.offroad_steps == 2


def test_time_to_collision_by_hand():
    road, (ego, _lead) = _road([(0.0, 0.0, 20.0), (30.0, 0.0, 10.0)])
    s = SafetyScore(dt=0.2, route_length_m=100.0)
    s.update(road, ego, _info())
    # centre gap 30 m minus two half-lengths (2.5 + 2.5) = 25 m, closing at 10 m/s
    assert s.result()["min_ttc_s"] == pytest.approx(2.5)


def test_driving_score_is_completion_times_penalties():
    road, (v,) = _road([(10.0, 0.0, 10.0)])
    s = SafetyScore(dt=1.0, route_length_m=50.0)
    for _ in range(4):
        s.update(road, v, _info())  # 40 m of progress
    s.collisions, s.offroad_events, s.lane_departures = 1, 2, 0
    r = s.result()
    assert r["route_completion"] == pytest.approx(0.8)
    assert r["driving_score"] == pytest.approx(0.8 * PENALTIES["collision"] * PENALTIES["offroad"] ** 2)


def test_progress_counts_only_the_along_road_component():
    road, (v,) = _road([(10.0, 0.0, 10.0)])
    s = SafetyScore(dt=1.0, route_length_m=100.0)
    s.update(road, v, _info(herr=math.pi / 3))
    assert s.distance_m == pytest.approx(10.0)
    assert s.progress_m == pytest.approx(5.0)
