"""Collect rendered frames with their ground truth, for training and evaluation."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from simroad._validation import check_int_in_range
from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments.rollout import drive_autopilot

__all__ = ["FrameSet", "collect_frames"]


@dataclass
class FrameSet:
    """Frames (uint8 RGB), GT road masks, GT noise masks and where each came from."""

    images: list[np.ndarray] = field(default_factory=list)
    masks: list[np.ndarray] = field(default_factory=list)
    noise_masks: list[dict[str, np.ndarray]] = field(default_factory=list)
    valid: list[np.ndarray] = field(default_factory=list)
    source: list[tuple[str, int, int]] = field(default_factory=list)  # (scenario, seed, step)


def collect_frames(
    *,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seeds: Iterable[int] = range(3),
    frames_per_seed: int = 10,
    every: int = 4,
    noise: str = "clear",
    severity: float = 0.5,
    steer_noise: float = 0.08,
    env_options: dict | None = None,
) -> FrameSet:
    """Drive the ground-truth autopilot (with a little seeded steering noise, so the
    car is not always centred) and keep every ``every``-th frame.

    Parameters
    ----------
    scenarios : sequence of str
    seeds : iterable of int
        One episode per scenario and seed; each seed is a new world palette.
    frames_per_seed : int
        Frames kept per episode.
    every : int
        Policy steps between kept frames.
    noise, severity : str, float
        Weather of the frames.
    steer_noise : float
        Standard deviation of the steering action added to the autopilot's.
    """
    frames_per_seed = check_int_in_range("frames_per_seed", frames_per_seed, 1, 100_000)
    every = check_int_in_range("every", every, 1, 1000)
    out = FrameSet()
    for scenario in scenarios:
        for seed in seeds:
            env = RoadCamEnv(scenario=scenario, noise=noise, severity=severity, **(env_options or {}))
            obs, info = env.reset(seed=int(seed))
            rng = np.random.default_rng([int(seed), 7])
            valid = env.camera.ground_valid.copy()
            for i in range(frames_per_seed):
                out.images.append(obs)
                out.masks.append(info["road_mask"])
                out.noise_masks.append(info["noise_masks"])
                out.valid.append(valid)
                out.source.append((scenario, int(seed), i * every))
                obs, info = drive_autopilot(
                    env, every, reset_seed=int(seed) + 10_000 + i, rng=rng, steer_noise=steer_noise
                )
            env.close()
    return out
