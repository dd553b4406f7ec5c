"""Collect rendered frames with their ground truth, for training and evaluation."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from simroad.core.validation import check_choice, check_in_range, check_int_in_range
from simroad.envs import SCENARIO_NAMES, RoadCamConfig, RoadCamEnv
from simroad.errors import InvalidParameterError
from simroad.experiments.rollout import drive_autopilot
from simroad.noise import parse_noise

__all__ = ["FrameSet", "check_frame_protocol", "collect_frames"]


@dataclass
class FrameSet:
    """Frames (uint8 RGB), GT road masks, GT noise masks and where each came from."""

    images: list[np.ndarray] = field(default_factory=list)
    masks: list[np.ndarray] = field(default_factory=list)
    noise_masks: list[dict[str, np.ndarray]] = field(default_factory=list)
    valid: list[np.ndarray] = field(default_factory=list)
    source: list[tuple[str, int, int]] = field(default_factory=list)  # (scenario, seed, step)


def check_frame_protocol(
    *, scenarios: Sequence[str], seeds: Iterable[int], noise: str, severity: float
) -> tuple[tuple[str, ...], tuple[int, ...]]:
    """Validate which frames to render before the first one is: scenarios (one or more
    known names), seeds (one or more integers in [0, 2**31 - 1]), the weather spec and
    its severity in [0, 1]. Returns the scenarios and seeds as tuples."""
    if isinstance(scenarios, str) or not isinstance(scenarios, Iterable):
        raise InvalidParameterError(
            f"scenarios: expected a list of scenario names, got {type(scenarios).__name__} {scenarios!r}."
        )
    names = tuple(check_choice("scenarios", s, SCENARIO_NAMES) for s in scenarios)
    if not names:
        raise InvalidParameterError(f"scenarios: expected at least one of {', '.join(SCENARIO_NAMES)}, got none.")
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, Iterable):
        raise InvalidParameterError(
            f"seeds: expected a list or range of integer seeds, got {type(seeds).__name__} {seeds!r}."
        )
    worlds = tuple(check_int_in_range("seeds", s, 0, 2**31 - 1) for s in seeds)
    if not worlds:
        raise InvalidParameterError("seeds: expected at least one seed, got none (e.g. range(100, 105)).")
    parse_noise(noise)
    check_in_range("severity", severity, 0.0, 1.0)
    return names, worlds


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
    scenarios, seeds = check_frame_protocol(scenarios=scenarios, seeds=seeds, noise=noise, severity=severity)
    frames_per_seed = check_int_in_range("frames_per_seed", frames_per_seed, 1, 100_000)
    every = check_int_in_range("every", every, 1, 1000)
    check_in_range("steer_noise", steer_noise, 0.0, 2.0)
    if env_options is not None and not isinstance(env_options, dict):
        raise InvalidParameterError(
            f"env_options: expected a dict of RoadCam options, got {type(env_options).__name__}."
        )
    RoadCamConfig.from_kwargs(scenario=scenarios[0], noise=noise, severity=severity, **(env_options or {}))
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
