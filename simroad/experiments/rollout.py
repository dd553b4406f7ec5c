"""Drive a RoadCam environment with the ground-truth autopilot (frame collection, export, figures)."""

from __future__ import annotations

from typing import Any

import numpy as np

from simroad.control.autopilot import autopilot_action
from simroad.core.validation import check_int_in_range
from simroad.envs import RoadCamEnv

__all__ = ["autopilot_env_action", "drive_autopilot"]


def autopilot_env_action(env: RoadCamEnv) -> np.ndarray:
    """The autopilot's action in ``env``'s action space: float32 ``[steering]``, or
    ``[steering, 0.0]`` (speed held) when the env is ``longitudinal``."""
    steer = autopilot_action(env.highway_env.road, env.vehicle)
    if env.config.longitudinal:
        return np.array([steer, 0.0], dtype=np.float32)
    return np.array([steer], dtype=np.float32)


def drive_autopilot(
    env: RoadCamEnv,
    steps: int,
    *,
    reset_seed: int | None = None,
    rng: np.random.Generator | None = None,
    steer_noise: float = 0.0,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Step ``env`` ``steps`` times with the autopilot; return the last observation and info.

    Parameters
    ----------
    env : RoadCamEnv
        A reset environment.
    steps : int
        Policy steps to drive, >= 1.
    reset_seed : int, optional
        When the episode ends (terminated or truncated), reset with this seed and
        drive on; None ignores the end of the episode.
    rng : numpy.random.Generator, optional
        With ``rng``, each steering action gets Gaussian noise of standard
        deviation ``steer_noise`` (action units), clipped to [-1, 1].
    steer_noise : float
        See ``rng``.

    Returns
    -------
    obs : ndarray of uint8, shape (H, W, 3)
    info : dict
        The environment's ``info`` of that observation.
    """
    steps = check_int_in_range("steps", steps, 1, 10**9)
    for _ in range(steps):
        action = autopilot_env_action(env)
        if rng is not None:
            action[0] = np.clip(action[0] + rng.normal(0.0, steer_noise), -1.0, 1.0)
        obs, _, terminated, truncated, info = env.step(action)
        if reset_seed is not None and (terminated or truncated):
            obs, info = env.reset(seed=reset_seed)
    return obs, info
