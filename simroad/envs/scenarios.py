"""The three scenarios, translated to highway-env environments at this one boundary.

``racetrack``
    highway-env's curvy two-lane circuit (``RacetrackEnv``), one other car.
``highway``
    highway-env's straight multi-lane motorway with IDM traffic.
``winding``
    :class:`simroad.envs.winding.WindingRoadEnv`, a two-lane country road generated
    from the seed: straights and arcs, >= 1.5 km, radii >= ~43 m (lane centre).
"""

from __future__ import annotations

from collections.abc import Callable

from highway_env.envs.common.abstract import AbstractEnv
from highway_env.envs.highway_env import HighwayEnv
from highway_env.envs.racetrack_env import RacetrackEnv

from simroad.envs.winding import WindingRoadEnv

__all__ = ["SCENARIOS", "make_highway_env"]


#: Every scenario simulates at 15 Hz and takes a camera frame and an action at 5 Hz.
_TIMING = {"simulation_frequency": 15, "policy_frequency": 5}


def _action(longitudinal: bool) -> dict:
    return {
        "type": "ContinuousAction",
        "longitudinal": bool(longitudinal),
        "lateral": True,
        "clip": True,
    }


def _racetrack(longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    return RacetrackEnv(
        config={
            "observation": {"type": "Kinematics"},
            "action": _action(longitudinal),
            "other_vehicles": 1 if traffic else 0,
            "terminate_off_road": False,
            "duration": duration_s,
            "offscreen_rendering": True,
            **_TIMING,
        }
    )


def _highway(longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    return HighwayEnv(
        config={
            "observation": {"type": "Kinematics"},
            "action": _action(longitudinal),
            "lanes_count": 3,
            "vehicles_count": 15 if traffic else 0,
            "duration": duration_s,
            "offroad_terminal": False,
            "offscreen_rendering": True,
            **_TIMING,
        }
    )


def _winding(longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    return WindingRoadEnv(
        config={
            "action": _action(longitudinal),
            "leading_vehicles": 1 if traffic else 0,
            "oncoming_vehicles": 3 if traffic else 0,
            "duration": duration_s,
            "offscreen_rendering": True,
            **_TIMING,
        }
    )


#: Scenario name -> factory(longitudinal, traffic, duration_s) of a highway-env env.
SCENARIOS: dict[str, Callable[[bool, bool, float], AbstractEnv]] = {
    "racetrack": _racetrack,
    "highway": _highway,
    "winding": _winding,
}


def make_highway_env(scenario: str, *, longitudinal: bool, traffic: bool, duration_s: float) -> AbstractEnv:
    """Create the highway-env environment behind ``scenario`` (a key of :data:`SCENARIOS`)."""
    return SCENARIOS[scenario](longitudinal, traffic, duration_s)
