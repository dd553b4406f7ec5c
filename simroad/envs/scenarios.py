"""The scenario registry: one frozen spec per scenario, every fact about it in one place.

``racetrack``
    highway-env's curvy two-lane circuit (``RacetrackEnv``), one other car.
``highway``
    highway-env's straight multi-lane motorway with IDM traffic.
``winding``
    :class:`simroad.envs.winding.WindingRoadEnv`, a two-lane country road generated
    from the seed: straights and arcs, >= 1.5 km, radii >= ~43 m (lane centre).
``town``
    :class:`simroad.envs.town.TownStreetEnv`, a town street generated from the seed:
    blocks of 60-120 m, junctions crossed straight on, parking strips with parked
    cars, zebra crossings and stop lines; kerbs and sidewalks (``profile="urban"``).

Each :class:`ScenarioSpec` holds the policy and simulation rates, the nominal lane
width and cruise speed (the controller's map priors), the scored route, the traffic
defaults and the factory of the highway-env environment; control and experiments
read them from here (:func:`get_scenario`). The translation to highway-env's config
dict happens only in the factories below.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from highway_env.envs.common.abstract import AbstractEnv
from highway_env.envs.highway_env import HighwayEnv
from highway_env.envs.racetrack_env import RacetrackEnv

from simroad.core.names import PROFILES
from simroad.core.validation import check_choice, check_in_range, check_int_in_range
from simroad.errors import InvalidParameterError

__all__ = [
    "OPEN_ROUTE_M",
    "POLICY_HZ",
    "SCENARIOS",
    "SCENARIO_NAMES",
    "SIMULATION_HZ",
    "ScenarioSpec",
    "generated_road_config",
    "get_scenario",
    "make_highway",
    "make_highway_env",
    "make_racetrack",
]

#: Camera frames and actions per simulated second, in Hz (every scenario).
POLICY_HZ = 5
#: highway-env physics steps per simulated second, in Hz (every scenario).
SIMULATION_HZ = 15
#: Route length scored on open roads, in m.
OPEN_ROUTE_M = 1000.0


#: factory(spec, longitudinal, traffic, duration_s) -> highway-env environment.
EnvFactory = Callable[["ScenarioSpec", bool, bool, float], AbstractEnv]


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything simroad knows about one scenario.

    Parameters
    ----------
    name : str
        Registry key, e.g. ``"racetrack"``.
    summary : str
        One line for help texts.
    factory : str
        Entry point ``"module:function"`` of ``function(spec, longitudinal, traffic,
        duration_s)``, which creates the highway-env environment; use :meth:`make_env`.
        A string, as in gymnasium's registry: the module is imported only when an
        environment is made, so the generated roads may read their defaults from
        :data:`SCENARIOS`.
    lane_width_m : float
        Nominal lane width in m (the road's: highway-env's own on the racetrack and
        the highway, the generated road's on ``winding``).
    cruise_speed_m_s : float
        Cruise speed of the drivers in m/s.
    lanes_count : int
        Lanes in the ego's direction of travel.
    route_is_lap : bool
        True when the ego's lanes close into a ring: episodes are then scored
        against one lap (measured on the network at reset), else against
        ``route_m``.
    route_m : float
        Route length in m of an open road (and of a lap scenario whose lanes
        unexpectedly do not close).
    traffic_vehicles : mapping of str to int
        highway-env config keys that count other vehicles, with their values when
        traffic is on (all are 0 with ``traffic=False``).
    policy_hz, simulation_hz : int
        Policy (camera frame and action) and physics rates in Hz; ``simulation_hz``
        is a multiple of ``policy_hz``.
    parking_width_m : float
        Nominal width in m of the parking strips beside the kerb (0: none); the
        controller's prior that a road edge may lie that much farther out.
    profile : str
        What lies beside the road (:data:`PROFILES`): ``"rural"`` verges (shoulder,
        grass, dirt, ...) or ``"urban"`` kerbs and sidewalks; the world's palette and
        scenery read it.
    """

    name: str
    summary: str
    factory: str
    lane_width_m: float
    cruise_speed_m_s: float
    lanes_count: int
    route_is_lap: bool = False
    route_m: float = OPEN_ROUTE_M
    traffic_vehicles: Mapping[str, int] = field(default_factory=dict)
    policy_hz: int = POLICY_HZ
    simulation_hz: int = SIMULATION_HZ
    parking_width_m: float = 0.0
    profile: str = "rural"

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"name: expected a non-empty scenario name, got {self.name!r}.")
        if not isinstance(self.factory, str) or not re.fullmatch(r"[\w.]+:\w+", self.factory):
            raise InvalidParameterError(
                f"factory: expected an entry point 'module:function' creating a highway-env env, got {self.factory!r}."
            )
        check_in_range("lane_width_m", self.lane_width_m, 1.0, 10.0, unit="m")
        check_in_range("cruise_speed_m_s", self.cruise_speed_m_s, 0.0, 60.0, unit="m/s")
        check_int_in_range("lanes_count", self.lanes_count, 1, 20)
        check_in_range("route_m", self.route_m, 1.0, 1e6, unit="m")
        check_int_in_range("policy_hz", self.policy_hz, 1, 100)
        check_int_in_range("simulation_hz", self.simulation_hz, 1, 1000)
        if self.simulation_hz % self.policy_hz:
            raise InvalidParameterError(
                f"simulation_hz: expected a multiple of policy_hz={self.policy_hz} Hz, got {self.simulation_hz} Hz."
            )
        check_in_range("parking_width_m", self.parking_width_m, 0.0, 10.0, unit="m")
        check_choice("profile", self.profile, PROFILES)
        for key, count in self.traffic_vehicles.items():
            check_int_in_range(f"traffic_vehicles[{key!r}]", count, 0, 1000)
        object.__setattr__(self, "traffic_vehicles", MappingProxyType(dict(self.traffic_vehicles)))

    @property
    def policy_period_s(self) -> float:
        """Simulated seconds between two camera frames (and actions)."""
        return 1.0 / self.policy_hz

    def make_env(self, *, longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
        """Create the highway-env environment of this scenario."""
        module, function = self.factory.split(":")
        factory: EnvFactory = getattr(importlib.import_module(module), function)
        return factory(self, longitudinal, traffic, duration_s)

    def highway_env_config(self, *, longitudinal: bool, traffic: bool, duration_s: float) -> dict[str, Any]:
        """The config keys every scenario's highway-env environment shares."""
        return {
            "action": {"type": "ContinuousAction", "longitudinal": bool(longitudinal), "lateral": True, "clip": True},
            "duration": duration_s,
            "offscreen_rendering": True,
            "simulation_frequency": self.simulation_hz,
            "policy_frequency": self.policy_hz,
            **{key: count if traffic else 0 for key, count in self.traffic_vehicles.items()},
        }


#: highway-env's observation of every scenario: none. simroad renders its own camera and
#: never reads highway-env's; its default (Kinematics, built with pandas each step) took
#: a third of a closed-loop step. An empty attribute list draws nothing and computes
#: nothing, so the simulation is the same.
HIGHWAY_OBSERVATION: dict[str, Any] = {"type": "AttributesObservation", "attributes": []}


def make_racetrack(spec: ScenarioSpec, longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    config = spec.highway_env_config(longitudinal=longitudinal, traffic=traffic, duration_s=duration_s)
    return RacetrackEnv(config={"observation": HIGHWAY_OBSERVATION, "terminate_off_road": False, **config})


def make_highway(spec: ScenarioSpec, longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    config = spec.highway_env_config(longitudinal=longitudinal, traffic=traffic, duration_s=duration_s)
    return HighwayEnv(
        config={
            "observation": HIGHWAY_OBSERVATION,
            "lanes_count": spec.lanes_count,
            "offroad_terminal": False,
            **config,
        }
    )


#: Scenario name -> its spec (insertion order is the order of help texts and figures).
SCENARIOS: dict[str, ScenarioSpec] = {
    "racetrack": ScenarioSpec(
        name="racetrack",
        summary="highway-env's curvy two-lane circuit, one other car",
        factory="simroad.envs.scenarios:make_racetrack",
        lane_width_m=5.0,
        cruise_speed_m_s=10.0,
        lanes_count=2,
        route_is_lap=True,
        traffic_vehicles={"other_vehicles": 1},
    ),
    "highway": ScenarioSpec(
        name="highway",
        summary="a straight three-lane motorway with IDM traffic",
        factory="simroad.envs.scenarios:make_highway",
        lane_width_m=4.0,
        cruise_speed_m_s=25.0,
        lanes_count=3,
        traffic_vehicles={"vehicles_count": 15},
    ),
    "winding": ScenarioSpec(
        name="winding",
        summary="a two-lane country road generated from the seed",
        factory="simroad.envs.winding:make_winding",
        lane_width_m=3.5,
        cruise_speed_m_s=15.0,
        lanes_count=1,
        traffic_vehicles={"leading_vehicles": 1, "oncoming_vehicles": 3},
    ),
    "town": ScenarioSpec(
        name="town",
        summary="a town street with junctions, parked cars and crossings, generated from the seed",
        factory="simroad.envs.town:make_town",
        lane_width_m=3.25,
        cruise_speed_m_s=12.0,
        lanes_count=1,
        route_m=600.0,
        traffic_vehicles={"leading_vehicles": 1, "oncoming_vehicles": 4, "parked_vehicles": 40},
        parking_width_m=2.3,
        profile="urban",
    ),
}

#: The scenario names, in registry order.
SCENARIO_NAMES: tuple[str, ...] = tuple(SCENARIOS)


def get_scenario(name: str) -> ScenarioSpec:
    """The spec of scenario ``name``; unknown names are refused with the valid ones
    listed and the closest one suggested."""
    return SCENARIOS[check_choice("scenario", name, SCENARIO_NAMES)]


def make_highway_env(scenario: str, *, longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    """Create the highway-env environment behind ``scenario`` (a key of :data:`SCENARIOS`)."""
    return get_scenario(scenario).make_env(longitudinal=longitudinal, traffic=traffic, duration_s=duration_s)


def generated_road_config(spec: ScenarioSpec) -> dict[str, Any]:
    """highway-env config keys every road simroad generates (winding, town) shares:
    observation and action types, rates, traffic counts, ego speed, from ``spec``."""
    return {
        "observation": HIGHWAY_OBSERVATION,
        "action": {"type": "ContinuousAction", "longitudinal": False, "lateral": True},
        "simulation_frequency": spec.simulation_hz,
        "policy_frequency": spec.policy_hz,
        "duration": 200,
        "lane_width": spec.lane_width_m,
        **spec.traffic_vehicles,
        "ego_speed": spec.cruise_speed_m_s,
        "collision_reward": -1,
    }
