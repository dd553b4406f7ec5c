"""Reproduce the shipped detector: ``simroad train-detector``."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from simroad.envs import SCENARIO_NAMES
from simroad.experiments.frames import collect_frames

__all__ = ["TRAIN_SEEDS", "train_detector"]

#: Seeds of the shipped model's training worlds; evaluation uses seeds >= 100.
TRAIN_SEEDS = tuple(range(16))


def train_detector(
    out: str | os.PathLike | None = None,
    *,
    seeds: Sequence[int] = TRAIN_SEEDS,
    frames_per_seed: int = 12,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seed: int = 0,
) -> Path:
    """Render clean frames of every scenario (one world palette per seed), fit the
    default detector on them and save it (npz) to ``out`` (default: the package's
    shipped model file). Returns the path written."""
    from simroad.detector import default_model_path, train_default

    frames = collect_frames(scenarios=scenarios, seeds=seeds, frames_per_seed=frames_per_seed, every=6)
    det = train_default(frames.images, frames.masks, rng=seed)
    path = Path(out) if out is not None else default_model_path()
    det.save(path)
    return path
