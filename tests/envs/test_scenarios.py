"""The scenario registry: one spec per scenario, read by the env, control and experiments."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import simroad
from simroad import SimroadError
from simroad.envs import SCENARIO_NAMES, SCENARIOS, RoadCamEnv, ScenarioSpec, get_scenario
from simroad.envs.routes import follow_lanes, lap_length_m


def test_specs_know_their_name():
    for name, spec in SCENARIOS.items():
        assert spec.name == name and get_scenario(name) is spec
        assert spec.policy_hz == 5 and spec.simulation_hz == 15 and spec.policy_period_s == 0.2


def test_unknown_scenario_suggests_the_closest():
    with pytest.raises(SimroadError, match="Did you mean 'winding'"):
        get_scenario("windng")


@pytest.mark.parametrize(
    "change, name",
    [
        ({"lane_width_m": 0.5}, "lane_width_m"),
        ({"cruise_speed_m_s": -1.0}, "cruise_speed_m_s"),
        ({"lanes_count": 0}, "lanes_count"),
        ({"route_m": 0.0}, "route_m"),
        ({"policy_hz": 0}, "policy_hz"),
        ({"simulation_hz": 16}, "simulation_hz"),
        ({"traffic_vehicles": {"vehicles_count": -1}}, "traffic_vehicles"),
        ({"factory": None}, "factory"),
    ],
)
def test_spec_validation_names_the_field(change, name):
    with pytest.raises(SimroadError, match=name):
        dataclasses.replace(get_scenario("highway"), **change)


def test_specs_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        get_scenario("highway").cruise_speed_m_s = 30.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        get_scenario("highway").traffic_vehicles["vehicles_count"] = 3  # type: ignore[index]


@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
@pytest.mark.parametrize("traffic", [True, False])
def test_the_highway_env_gets_the_specs_facts(scenario, traffic):
    spec = get_scenario(scenario)
    env = RoadCamEnv(scenario=scenario, traffic=traffic)
    hw = env.highway_env.config
    assert hw["policy_frequency"] == spec.policy_hz and hw["simulation_frequency"] == spec.simulation_hz
    assert env.dt == spec.policy_period_s and env.scenario is spec
    for key, count in spec.traffic_vehicles.items():
        assert hw[key] == (count if traffic else 0)
    env.reset(seed=0)
    lane = env.highway_env.road.network.get_lane(env.vehicle.lane_index)
    assert lane.width_at(0.0) == pytest.approx(spec.lane_width_m)


def test_routes_lap_on_the_racetrack_and_open_elsewhere():
    env = RoadCamEnv(scenario="racetrack")
    env.reset(seed=0)
    net, v = env.highway_env.road.network, env.vehicle
    lap = lap_length_m(net, v.lane_index, position=v.position)
    assert get_scenario("racetrack").route_is_lap and lap is not None and 200.0 < lap < 2000.0
    ring = [index for (index, _lane), _ in zip(follow_lanes(net, v.lane_index, position=v.position), range(100))]
    assert ring.count(v.lane_index) >= 2  # the walk goes round
    env = RoadCamEnv(scenario="winding")
    env.reset(seed=0)
    net, v = env.highway_env.road.network, env.vehicle
    assert lap_length_m(net, v.lane_index, position=v.position) is None
    chain = [lane.length for _, lane in follow_lanes(net, v.lane_index, position=v.position)]
    assert len(chain) == len(env.highway_env.segments) and sum(chain) >= 1500.0


def _imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
    return out


def test_envs_import_nothing_from_control_or_experiments():
    envs_dir = Path(simroad.__file__).parent / "envs"
    files = sorted(envs_dir.glob("*.py"))
    assert len(files) >= 5
    for path in files:
        bad = {
            m
            for m in _imported_modules(path)
            if m.split(".")[:2] in (["simroad", "control"], ["simroad", "experiments"])
        }
        assert not bad, f"{path.name} imports {sorted(bad)}"


def test_the_env_carries_no_policy():
    assert not hasattr(RoadCamEnv, "autopilot_action")


def test_scenario_spec_is_exported():
    assert isinstance(get_scenario("racetrack"), ScenarioSpec)
    assert np.isclose(get_scenario("winding").lane_width_m, 3.5)
