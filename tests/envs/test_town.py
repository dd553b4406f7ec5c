"""The town street: seeded layout, a straight route through the junctions, parked cars
that stay parked, crossings on the road surface, and the oracle driving the route."""

from __future__ import annotations

import numpy as np
import pytest
from highway_env.road.road import RoadNetwork

from simroad.envs import get_scenario
from simroad.envs._town_parts import ParkedVehicle
from simroad.envs.routes import follow_lanes
from simroad.envs.town import TownStreetEnv, build_town_network, generate_town
from simroad.experiments.episode import EpisodeSpec, run_episode


def _town(seed: int) -> TownStreetEnv:
    env = TownStreetEnv()
    env.reset(seed=seed)
    return env


def _on_some_lane(network, xy: np.ndarray) -> np.ndarray:
    out = np.zeros(len(xy), dtype=bool)
    for lane in network.lanes_list():
        for k in np.nonzero(~out)[0]:
            s, lat = lane.local_coordinates(xy[k])
            out[k] = 0.0 <= s <= lane.length and abs(lat) <= lane.width_at(s) / 2.0
    return out


def test_same_seed_same_town_other_seed_other_town():
    a, b = generate_town(np.random.default_rng(3)), generate_town(np.random.default_rng(3))
    assert a == b
    assert a != generate_town(np.random.default_rng(4))
    assert sum(block.length_m for block in a.blocks) >= 600.0
    assert all(60.0 <= block.length_m <= 120.0 for block in a.blocks)


@pytest.mark.parametrize("seed", range(4))
def test_route_runs_straight_through_every_junction(seed):
    env = _town(seed)
    net, ego = env.road.network, env.vehicle
    walk = list(follow_lanes(net, ego.lane_index, position=ego.position))
    assert [index[0] for index, _ in walk] == env.route_nodes[:-1]  # the main street, no turn
    for (_, a), (_, b) in zip(walk[:-1], walk[1:]):
        np.testing.assert_allclose(a.position(a.length, 0), b.position(0, 0), atol=1e-6)
        turn = a.heading_at(a.length) - b.heading_at(0)
        assert abs(np.arctan2(np.sin(turn), np.cos(turn))) < 1e-6
    assert sum(lane.length for _, lane in walk) >= get_scenario("town").route_m
    # Inside every junction box, highway-env puts a car heading along the street on
    # the main street's lanes, and the box is road surface.
    assert len(env.junction_boxes) == len(env.layout.blocks)
    for box in env.junction_boxes:
        centre = box.mean(axis=0)
        for lateral in (-1.0, 1.0):
            forward = box[1] - box[0]
            heading = float(np.arctan2(forward[1], forward[0]))
            side = np.array([-np.sin(heading), np.cos(heading)])
            travel = heading if lateral > 0 else heading + np.pi  # drive on the right
            index = net.get_closest_lane_index(centre + lateral * side, travel)
            assert index[0][0] in "fo" and index[1][0] in "fo"
            assert net.get_lane(index).on_lane(centre + lateral * side)
        assert _on_some_lane(net, box * 0.999 + centre * 0.001).all()


def test_indexed_lookup_is_highway_envs():
    town = build_town_network(generate_town(np.random.default_rng(5)))
    plain = RoadNetwork()
    plain.graph = town.network.graph
    rng = np.random.default_rng(0)
    lo = np.min([lane.position(0, 0) for lane in plain.lanes_list()], axis=0) - 20
    hi = np.max([lane.position(lane.length, 0) for lane in plain.lanes_list()], axis=0) + 20
    for _ in range(300):
        p = rng.uniform(lo, hi)
        heading = float(rng.uniform(-np.pi, np.pi)) if rng.random() < 0.7 else None
        assert town.network.get_closest_lane_index(p, heading) == plain.get_closest_lane_index(p, heading)


def test_parked_cars_stay_parked_on_parking_strips():
    env = _town(1)
    parked = [v for v in env.road.vehicles if isinstance(v, ParkedVehicle)]
    assert len(parked) == env.config["parked_vehicles"] > 0
    before = np.array([v.position for v in parked])
    for _ in range(10):
        env.step(np.zeros(1, dtype=np.float32))
    after = np.array([v.position for v in parked])
    np.testing.assert_array_equal(before, after)
    assert all(v.speed == 0.0 for v in parked)
    for v in parked:
        assert v.lane_index[0].startswith("p") and v.lane.on_lane(v.position)
        corners = v.polygon()[:4]
        assert _on_some_lane(env.road.network, corners).all()  # wholly on the strip's asphalt


def test_crossings_lie_on_the_road():
    for seed in range(3):
        env = _town(seed)
        polys = env.crossing_polygons
        assert len(polys) >= len(env.layout.blocks)  # a stop line per junction at least
        zebras = sum(block.crossing for block in env.layout.blocks)
        assert zebras > 0
        for poly in polys:
            assert poly.shape[1] == 2
            inner = poly * 0.999 + poly.mean(axis=0) * 0.001
            assert _on_some_lane(env.road.network, inner).all()


def test_no_parking_on_the_egos_kerb_by_default():
    layout = generate_town(np.random.default_rng(0))
    assert not any(block.parking_right for block in layout.blocks)
    assert any(block.parking_left for block in layout.blocks)
    with_own = generate_town(np.random.default_rng(0), ego_side_parking=True)
    assert any(block.parking_right for block in with_own.blocks)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_oracle_drives_the_town_route(seed):
    rec = run_episode(EpisodeSpec(scenario="town", seed=seed, steps=300, driver="oracle"))
    assert rec["route_completion"] == 1.0
    assert rec["offroad_steps"] == 0 and not rec["collided"]
    assert rec["lateral_rmse_m"] <= 0.3
