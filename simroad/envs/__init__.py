"""Gymnasium environments: ``simroad/RoadCam-v0`` and the scenarios behind it."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from simroad.envs.config import RoadCamConfig
from simroad.envs.roadcam import RoadCamEnv
from simroad.envs.scenarios import SCENARIO_NAMES, SCENARIOS, ScenarioSpec, get_scenario

__all__ = ["ENV_ID", "SCENARIOS", "SCENARIO_NAMES", "RoadCamConfig", "RoadCamEnv", "ScenarioSpec", "get_scenario"]

ENV_ID = "simroad/RoadCam-v0"

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="simroad.envs.roadcam:RoadCamEnv")
