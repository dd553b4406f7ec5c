"""Write the demo's videos (``simroad videos``): one short detector episode per noise.

``make demo`` runs the small ablation of ``experiments/demo.toml`` (tables and
figures in ``runs/demo``), then ``simroad videos --out runs/demo/videos`` writes
``NOISE.gif`` per noise: the noisy camera view with the predicted road mask
(green), the ground-truth outline (yellow) and a bird's-eye inset with the
trajectory.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tqdm import tqdm

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.validation import check_output_dir, ensure_writable_dir
from simroad.errors import InvalidParameterError
from simroad.experiments.episode import EpisodeSpec, run_episode
from simroad.filters import parse_filters

__all__ = ["DEMO_NOISES", "write_videos"]

#: The weathers of the demo videos, one GIF each.
DEMO_NOISES = ("clear", "rain", "snow", "shadow", "glare")


def write_videos(
    out: str | os.PathLike,
    *,
    scenario: str = "winding",
    seed: int = 0,
    steps: int = 60,
    severity: float = 0.7,
    noises: tuple[str, ...] = DEMO_NOISES,
    filters: str = "all",
    detector: str = "paper",
    detector_options: Mapping[str, Any] | None = None,
    progress: bool = True,
    camera_profile: CameraProfile | str | os.PathLike | None = None,
    compare: str | None = "none",
) -> list[Path]:
    """One captioned GIF per noise of the detector driver (by default the paper's with
    all filters), beside it the same detector with the ``compare`` filters on the same
    frames (by default none: without and with filters side by side).

    Parameters
    ----------
    out : path
        Output directory (created); the files are ``OUT/NOISE.gif``.
    scenario : str, optional
        The world (default ``winding``: a new country road per seed).
    seed : int, optional
        Episode seed.
    steps : int, optional
        Policy steps per video (one frame each).
    severity : float, optional
        Weather severity in [0, 1].
    noises : tuple of str, optional
        Weathers, one video each (default :data:`DEMO_NOISES`).
    filters : str, optional
        The filter set in front of the detector (``none``, ``all``, names joined by ``+``).
    detector, detector_options : optional
        The detector spec and its keyword options (:mod:`simroad.detector.registry`).
    progress : bool, optional
        Show a progress bar.
    camera_profile : CameraProfile, dict or path, optional
        The camera of the videos (RoadCam's ``camera_profile``, e.g. a TOML file
        from ``simroad calibrate``); None is simroad's default profile.
    compare : str or None, optional
        The filter set of the left view (it does not drive); None, or the same set as
        ``filters``, gives one view.

    Returns
    -------
    list of Path
        The videos written, in the order of ``noises``.
    """
    if isinstance(noises, str) or not noises:
        raise InvalidParameterError(f"noises: expected a tuple of weathers such as ('clear', 'rain'), got {noises!r}.")
    check_output_dir("out", out)
    options = {} if camera_profile is None else {"camera_profile": resolve_profile(camera_profile)}
    specs = [  # every episode checked before the first one runs
        EpisodeSpec(scenario=scenario, noise=noise, severity=severity, filters=parse_filters(filters),
                    seed=seed, steps=steps, route_m=1e4, env_options=options, detector=detector,
                    detector_options=dict(detector_options or {}))
        for noise in noises
    ]  # fmt: skip
    if compare is not None:
        try:
            same = parse_filters(compare) == parse_filters(filters)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"compare: {str(exc).removeprefix('filters: ')}") from None
        compare = None if same else compare  # the same filters twice: one view
    directory = ensure_writable_dir("out", out)
    paths = []
    for noise, spec in tqdm(list(zip(noises, specs)), desc="videos", unit="video", disable=not progress):
        path = directory / f"{noise}.gif"
        run_episode(spec, video=str(path), video_compare=compare)
        paths.append(path)
    return paths
