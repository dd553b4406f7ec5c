"""Gymnasium environments: ``simroad/RoadCam-v0`` and the scenarios behind it."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from simroad.envs.config import SCENARIO_NAMES, RoadCamConfig
from simroad.envs.roadcam import RoadCamEnv

__all__ = ["ENV_ID", "SCENARIO_NAMES", "RoadCamConfig", "RoadCamEnv"]

ENV_ID = "simroad/RoadCam-v0"

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="simroad.envs.roadcam:RoadCamEnv")
