"""Train a road detector like the shipped one (``simroad train-detector``)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.names import TRAIN_SEEDS
from simroad.core.validation import check_int_in_range
from simroad.detector import train_default
from simroad.detector.persistence import check_model_destination
from simroad.envs import SCENARIO_NAMES
from simroad.experiments.frames import check_frame_protocol, collect_frames

__all__ = [
    "DEFAULT_MODEL_FILE",
    "TRAIN_FRAMES_PER_SEED",
    "check_writable_file",
    "train_detector",
]

#: Frames kept per scenario and training seed (one every 6 policy steps).
TRAIN_FRAMES_PER_SEED = 12
#: Where ``simroad train-detector`` writes by default: this name in the working
#: directory (never the installed package).
DEFAULT_MODEL_FILE = "road_detector.npz"


def check_writable_file(name: str, path: str | os.PathLike) -> Path:
    """Check that a model file can be written at ``path``, creating its parent folders.

    The same check as :meth:`RoadDetector.save` makes
    (:func:`~simroad.detector.check_model_destination`), run before any frame is
    rendered; raises :class:`SimroadError` naming ``name``.
    """
    return check_model_destination(path, name=name, make_parents=True)


def train_detector(
    out: str | os.PathLike = DEFAULT_MODEL_FILE,
    *,
    seeds: Sequence[int] = TRAIN_SEEDS,
    frames_per_seed: int = TRAIN_FRAMES_PER_SEED,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seed: int = 0,
    camera_profile: CameraProfile | str | os.PathLike | None = None,
) -> Path:
    """Render clean frames and fit the default detector on them, as for the shipped model.

    Parameters
    ----------
    out : path, optional
        The ``.npz`` file to write (default: ``road_detector.npz`` in the current
        working directory). Checked to be writable before any frame is rendered;
        the package's own model file is only replaced if you name it here.
    seeds : sequence of int, optional
        Training worlds, one world palette each (default :data:`TRAIN_SEEDS`).
    frames_per_seed : int, optional
        Frames per scenario and seed, one every 6 policy steps.
    scenarios : sequence of str, optional
        Scenarios rendered (default: all).
    seed : int, optional
        Seeds the choice of training pixels.
    camera_profile : CameraProfile, dict or path, optional
        The camera of every frame (RoadCam's ``camera_profile``, e.g. a TOML file
        from ``simroad calibrate``); None is simroad's default profile.

    Returns
    -------
    Path
        The file written; load it with ``RoadDetector.load(path)`` or pass it to
        ``simroad evaluate-detector --model PATH``.
    """

    check_frame_protocol(scenarios=scenarios, seeds=seeds, noise="clear", severity=0.0)
    check_int_in_range("frames_per_seed", frames_per_seed, 1, 100_000)
    check_int_in_range("seed", seed, 0, 2**32 - 1)
    options = {} if camera_profile is None else {"camera_profile": resolve_profile(camera_profile)}
    path = check_writable_file("out", out)
    frames = collect_frames(
        scenarios=scenarios, seeds=seeds, frames_per_seed=frames_per_seed, every=6, env_options=options
    )
    det = train_default(frames.images, frames.masks, rng=seed)
    det.save(path)
    return path
