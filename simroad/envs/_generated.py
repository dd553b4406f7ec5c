"""What the environments of the roads simroad generates (winding, town) share."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from highway_env import utils
from highway_env.envs.common.abstract import AbstractEnv

from simroad.envs.scenarios import ScenarioSpec, generated_road_config, get_scenario

__all__ = ["GeneratedRoadEnv"]


class GeneratedRoadEnv(AbstractEnv):
    """highway-env's ``AbstractEnv`` with simroad's episode rules: no reward of its
    own (simroad scores episodes itself), terminated by a crash, truncated after
    ``config["duration"]`` seconds.

    Its default config is the facts of the scenario ``scenario_name``
    (:func:`~simroad.envs.scenarios.generated_road_config`) and then the keys of the
    road's own generator, :meth:`_road_config`.
    """

    #: The scenario (:data:`~simroad.envs.scenarios.SCENARIOS`) whose facts are the defaults.
    scenario_name: ClassVar[str] = ""

    @classmethod
    def default_config(cls) -> dict:
        spec = get_scenario(cls.scenario_name)
        config = super().default_config()
        utils.update_config(config, {**generated_road_config(spec), **cls._road_config(spec)})
        return config

    @classmethod
    def _road_config(cls, spec: ScenarioSpec) -> dict[str, Any]:
        """The config keys of the road's generator (length, radii, ...) and their defaults."""
        return {}

    def _reward(self, action: np.ndarray) -> float:
        return 0.0

    def _is_terminated(self) -> bool:
        return bool(self.vehicle.crashed)

    def _is_truncated(self) -> bool:
        return bool(self.time >= self.config["duration"])
