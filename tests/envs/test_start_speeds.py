"""Cars start at a speed their planners would hold on the road they are on (issue 32)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad.core.constants import GRAVITY_M_S2
from simroad.envs import RoadCamEnv
from simroad.envs.routes import follow_lanes
from simroad.envs.tyres import EGO_GRIP_USE, GripIDMVehicle


def _pointwise_rule(env: RoadCamEnv, accel: float, reach_m: float) -> float:
    """min over the lane centre ahead, sampled every 0.5 m up to ``reach_m``, of
    sqrt(a / kappa + 2 a d): curvature from the heading's change along the centre line
    (an independent reading of the geometry, point by point, not lane by lane)."""
    net, ego = env.highway_env.road.network, env.vehicle
    s0, _ = net.get_lane(ego.lane_index).local_coordinates(ego.position)
    headings, step = [], 0.5
    offset = float(s0)
    for _, lane in follow_lanes(net, ego.lane_index, position=ego.position):
        s = offset
        while s < lane.length and len(headings) * step < reach_m:
            headings.append(float(lane.heading_at(s)))
            s += step
        offset = s - lane.length
        if len(headings) * step >= reach_m:
            break
    h = np.unwrap(np.asarray(headings))
    kappa = np.abs(np.diff(h)) / step
    d = np.arange(len(kappa)) * step
    with np.errstate(divide="ignore"):
        limits = np.sqrt(accel / kappa + 2.0 * accel * d)
    return float(limits.min())


@pytest.mark.parametrize("seed", range(4))
def test_on_ice_the_ego_starts_no_faster_than_the_curves_ahead_allow(seed):
    env = RoadCamEnv(scenario="winding", road_surface="ice", longitudinal=True, camera_effects=False)
    env.reset(seed=seed)
    mu = float(env.vehicle.mu)
    assert mu == pytest.approx(0.1)
    accel = EGO_GRIP_USE * mu * GRAVITY_M_S2
    cruise = 15.0
    reach = cruise**2 / (2.0 * accel)  # the stopping distance from the cruise speed
    start = float(env.vehicle.speed)
    rule = min(cruise, _pointwise_rule(env, accel, reach))
    assert start <= rule * 1.02  # at most the rule's speed (the heading sampled every 0.5 m)
    assert start >= 0.7 * rule  # and not far below it: the lanes' curvature, not a crawl
    assert start <= min(cruise, _pointwise_rule(env, accel, 100.0)) * 1.02  # the first 100 m alone
    env.close()


def test_traffic_starts_within_its_own_planners_grip():
    env = RoadCamEnv(scenario="winding", road_surface="ice", longitudinal=True, camera_effects=False)
    env.reset(seed=1)
    for v in env.highway_env.road.vehicles:
        if isinstance(v, GripIDMVehicle):
            limit = v.lanes_ahead.curve_speed_m_s(
                v, v.CORNER_USE * v.mu * GRAVITY_M_S2, v.CORNER_USE * v.mu * GRAVITY_M_S2
            )
            assert float(v.speed) <= limit + 1e-9
    env.close()


def test_a_dry_straight_start_keeps_the_cruise_speed_and_no_friction_keeps_it_in_snow():
    dry = RoadCamEnv(scenario="highway", road_surface="dry", longitudinal=True, camera_effects=False)
    dry.reset(seed=0)
    assert float(dry.vehicle.speed) == pytest.approx(25.0)  # a straight highway: nothing binds
    off = RoadCamEnv(scenario="winding", noise="snow", severity=0.8, friction=False, longitudinal=True,
                     camera_effects=False)  # fmt: skip
    off.reset(seed=0)
    assert float(off.vehicle.speed) == 15.0 and math.isinf(getattr(off.vehicle, "mu", math.inf))
    dry.close()
    off.close()
