"""Gymnasium environments: ``simroad/RoadCam-v0`` (registered by ``import simroad``) and the scenarios behind it."""

from __future__ import annotations

from simroad.envs.config import RoadCamConfig
from simroad.envs.roadcam import RoadCamEnv
from simroad.envs.scenarios import SCENARIO_NAMES, SCENARIOS, ScenarioSpec, get_scenario

__all__ = ["SCENARIOS", "SCENARIO_NAMES", "RoadCamConfig", "RoadCamEnv", "ScenarioSpec", "get_scenario"]
