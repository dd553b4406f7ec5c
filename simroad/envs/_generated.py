"""What the environments of the roads simroad generates (winding, town) share."""

from __future__ import annotations

import numpy as np
from highway_env.envs.common.abstract import AbstractEnv

__all__ = ["GeneratedRoadEnv"]


class GeneratedRoadEnv(AbstractEnv):
    """highway-env's ``AbstractEnv`` with simroad's episode rules: no reward of its
    own (simroad scores episodes itself), terminated by a crash, truncated after
    ``config["duration"]`` seconds."""

    def _reward(self, action: np.ndarray) -> float:
        return 0.0

    def _is_terminated(self) -> bool:
        return bool(self.vehicle.crashed)

    def _is_truncated(self) -> bool:
        return bool(self.time >= self.config["duration"])
