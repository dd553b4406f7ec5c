"""Fit a camera profile to the user's photographs (``simroad calibrate``).

:func:`calibrate_profile` searches the camera and daylight fields of a
:class:`~simroad.camera.profile.CameraProfile` (:data:`FIT_PARAMETERS`) so that the
appearance statistics (:mod:`simroad.metrics.appearance`) of simroad's clear frames
rendered with the profile match those of the photographs.

Every evaluation scores the same worlds (every scenario and seed, ``frames`` frames
each, the ground-truth autopilot driving): common random numbers, so the objective
changes only with the profile, not with the draw of worlds. The worlds are rendered
once and the camera's fields tried by exposing the recorded renders again
(:mod:`simroad.experiments.replay`): two hundred worlds per evaluation for the price
of a dozen, which is what keeps the fit from learning the daylight draws of a few
worlds instead of the camera. The daylight and asphalt fields change the world and
are tried by rendering it again, in a block of their own (:func:`calibrate_profile`).
The objective (:class:`CalibrationObjective`) is the mean, over the
statistics and the levels :data:`OBJECTIVE_LEVELS` (p10, p25, p50, p75, p90), of
the absolute difference between the frames' and the photos' quantiles, each in units
of how surely the photos know that quantile: its standard error, bootstrapped from
the photos, and at least :data:`UNIT_FLOOR` of the photos' p90 - p10 of the statistic.
A quantile that a few hundred photos pin down loosely (the top of ``saturated``,
``road_spread``) then counts less than one they pin down well, instead of pulling the
tone curve after the photos' sampling noise (measured: with every quantile in units
of the spread, the fit bent the tone curve from 1.3 to 1.19 to match the clipping of
one sample, and the road's spread missed). Quantiles move continuously with the
profile where the KS distance steps, so the search sees a slope. The search
is scipy's Nelder-Mead on the fitted fields mapped to [0, 1] (the white balance in
mired), starting from ``start`` (simroad's default profile), within
:data:`~simroad.camera.profile.PROFILE_RANGES` (the sky's brightness within
:data:`SKY_BRIGHTNESS_RANGE`). The fit is reported with the two-sample
Kolmogorov-Smirnov distance of each statistic, before and after.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import ks_2samp

from simroad.camera.profile import CameraProfile, save_profile
from simroad.core.validation import check_int_in_range, check_output_file
from simroad.envs import SCENARIO_NAMES
from simroad.errors import InvalidParameterError
from simroad.experiments.calibration_search import BlockSearch
from simroad.experiments.frames import check_frame_protocol, collect_frames
from simroad.experiments.pool import default_workers
from simroad.experiments.profile_space import (
    FIT_PARAMETERS,
    check_fit,
)
from simroad.experiments.realism import check_env_options, photo_statistics
from simroad.experiments.replay import record_worlds, replay_statistics
from simroad.metrics.appearance import STATISTICS, frame_appearance

__all__ = [
    "CALIBRATION_SEEDS",
    "OBJECTIVE_LEVELS",
    "UNIT_FLOOR",
    "CalibrationObjective",
    "CalibrationResult",
    "calibrate_from_photos",
    "calibrate_profile",
    "calibration_objective",
    "format_calibration",
    "ks_distances",
    "profile_statistics",
    "write_calibration",
]

#: Worlds the fit renders, per scenario (no other tuning uses them; realism uses
#: 5000-5012): 200 worlds in all, as many as a photo set of a few hundred frames
#: needs for the frames' quantiles to be as sure as the photos' (at a dozen worlds the
#: fit learns those worlds' daylight draws instead of the camera).
CALIBRATION_SEEDS = range(6000, 6050)
#: Quantile levels the objective compares.
OBJECTIVE_LEVELS = (0.1, 0.25, 0.5, 0.75, 0.9)
#: The smallest unit of a quantile difference, as a share of the statistic's scale (the
#: photos' p90 - p10): a photo set that pins a quantile down exactly must not make its
#: tiniest difference dominate the objective.
UNIT_FLOOR = 0.05
#: Resamples of the photos that estimate each quantile's standard error.
_BOOTSTRAP = 200
#: Smallest scale of a statistic (a photo set with no spread in a statistic must not
#: make its tiniest difference dominate the objective).
_SCALE_FLOOR = {"road_b": 1.0, "road_a": 1.0, "saturated": 0.002}
_DEFAULT_FLOOR = 0.02
#: Objective term of a statistic the frames have no value of.
_MISSING_TERM = 10.0
#: Policy steps between the frames of an evaluation (the first one is this far in).
_EVERY = 5


@dataclass(frozen=True)
class CalibrationResult:
    """A fitted profile and how well it matches the photographs.

    Attributes
    ----------
    profile, start : CameraProfile
        The fitted profile and the one the search started from.
    objective, start_objective : float
        :class:`CalibrationObjective` of each (0: the frames' quantiles equal the photos').
    ks, start_ks : dict
        ``{statistic: two-sample KS distance}`` between each profile's frames and the photos.
    fitted : tuple of str
        The fields the search moved.
    evaluations : int
        Profiles scored (each on every world's frames).
    renders : int
        Renders of the worlds (the others were exposures of recorded renders).
    frames : int
        Frames with statistics per evaluation (the fitted profile's).
    photos : int
        Photographs with statistics.
    source : str
        Where the photographs come from.
    """

    profile: CameraProfile
    start: CameraProfile
    objective: float
    start_objective: float
    ks: dict[str, float]
    start_ks: dict[str, float]
    fitted: tuple[str, ...]
    evaluations: int
    renders: int
    frames: int
    photos: int
    source: str


def profile_statistics(
    profile: CameraProfile,
    *,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seeds: Iterable[int] = CALIBRATION_SEEDS,
    frames: int = 3,
    every: int = _EVERY,
    env_options: Mapping[str, Any] | None = None,
) -> dict[str, np.ndarray]:
    """The appearance statistics of clear frames rendered with ``profile``.

    One episode per scenario and seed; frames at policy steps ``every``,
    ``2 * every``, ... of the ground-truth autopilot (the first frame, before the
    auto-exposure settles, is left out, as in ``simroad realism``). Frames with too
    little road have no statistics and are left out.

    Returns
    -------
    dict
        ``{statistic: float array (n_frames,)}`` (NaN where a statistic has no value).
    """
    options = {**(env_options or {}), "camera_profile": profile}
    fs = collect_frames(scenarios=scenarios, seeds=seeds, frames_per_seed=frames + 1, every=every, env_options=options)
    rows = [frame_appearance(rgb, road) for rgb, road, src in zip(fs.images, fs.masks, fs.source) if src[2] > 0]
    kept = [r for r in rows if r is not None]
    return {s: np.array([r[s] for r in kept], float) for s in STATISTICS}


def _finite(values: Iterable[float]) -> np.ndarray:
    v = np.asarray(list(values) if not isinstance(values, np.ndarray) else values, float).ravel()
    return v[np.isfinite(v)]


def _scales(reference: Mapping[str, np.ndarray]) -> dict[str, float]:
    """Each statistic's unit of quantile difference: the photos' p90 - p10, floored."""
    out = {}
    for s in STATISTICS:
        p10, p90 = np.quantile(reference[s], [0.1, 0.9])
        out[s] = max(float(p90 - p10), _SCALE_FLOOR.get(s, _DEFAULT_FLOOR))
    return out


class CalibrationObjective:
    """How far frames' statistics lie from the photos' (0 = the same quantiles).

    Built once per photo set: ``objective(values)`` is the mean over
    :data:`STATISTICS` and :data:`OBJECTIVE_LEVELS` of ``|q_frames - q_photos| / unit``,
    ``unit`` the standard deviation of the photos' quantile over :data:`_BOOTSTRAP`
    resamples of the photos (a generator seeded 0: the same photos, the same
    objective), at least :data:`UNIT_FLOOR` times the photos' p90 - p10 of the
    statistic (that at least 0.02; 1 for the Lab statistics, 0.002 for
    ``saturated``). NaNs are left out; a statistic without any finite frame value adds
    10 to the sum.

    Parameters
    ----------
    reference : mapping
        ``{statistic: per-photo values}``, a finite value of every statistic at least.
    """

    def __init__(self, reference: Mapping[str, Iterable[float]]) -> None:
        ref = {s: _finite(reference.get(s, ())) for s in STATISTICS}
        empty = [s for s, v in ref.items() if v.size == 0]
        if empty:
            raise InvalidParameterError(
                f"reference: no finite value of {', '.join(empty)}; a reference needs one each."
            )
        scales = _scales(ref)
        rng = np.random.default_rng(0)
        levels = np.asarray(OBJECTIVE_LEVELS)
        self.quantiles: dict[str, np.ndarray] = {}
        self.units: dict[str, np.ndarray] = {}
        for s in STATISTICS:
            v = ref[s]
            resampled = np.quantile(v[rng.integers(0, v.size, (_BOOTSTRAP, v.size))], levels, axis=1)
            self.quantiles[s] = np.quantile(v, levels)
            self.units[s] = np.maximum(resampled.std(axis=1), UNIT_FLOOR * scales[s])

    def __call__(self, values: Mapping[str, Iterable[float]]) -> float:
        terms = []
        for s in STATISTICS:
            v = _finite(values.get(s, ()))
            if v.size == 0:
                terms.append(_MISSING_TERM)
                continue
            diff = np.quantile(v, OBJECTIVE_LEVELS) - self.quantiles[s]
            terms.append(float(np.mean(np.abs(diff) / self.units[s])))
        return float(np.mean(terms))


def calibration_objective(values: Mapping[str, Iterable[float]], reference: Mapping[str, Iterable[float]]) -> float:
    """:class:`CalibrationObjective` of ``reference`` applied to ``values`` (for one
    evaluation; a search builds the objective once)."""
    return CalibrationObjective(reference)(values)


def ks_distances(values: Mapping[str, Iterable[float]], reference: Mapping[str, Iterable[float]]) -> dict[str, float]:
    """``{statistic: two-sample Kolmogorov-Smirnov distance}`` (NaN where a side has no value)."""
    out = {}
    for s in STATISTICS:
        a, b = _finite(values.get(s, ())), _finite(reference.get(s, ()))
        out[s] = float(ks_2samp(a, b).statistic) if a.size and b.size else math.nan
    return out


def calibrate_profile(
    reference: Mapping[str, Iterable[float]],
    *,
    source: str = "reference values",
    start: CameraProfile | None = None,
    fit: Sequence[str] = FIT_PARAMETERS,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seeds: Iterable[int] = CALIBRATION_SEEDS,
    frames: int = 1,
    max_evaluations: int = 24,
    max_replays: int = 200,
    workers: int | None = None,
    env_options: Mapping[str, Any] | None = None,
    progress: bool = False,
) -> CalibrationResult:
    """Fit the profile fields ``fit`` so that rendered clear frames look like ``reference``.

    The worlds (every scenario and seed) are rendered and recorded once
    (:func:`~simroad.experiments.replay.record_worlds`); the camera fields
    (:data:`~simroad.camera.profile.CAMERA_FIELDS`) are searched by exposing the
    recordings again with each profile tried (:func:`~simroad.experiments.replay.replay_statistics`,
    cheap); the daylight and asphalt fields by rendering the worlds again for each
    profile tried (dear), each with the camera that suits it
    (:mod:`simroad.experiments.calibration_search` has the plan).

    Parameters
    ----------
    reference : mapping
        ``{statistic: per-photo values}`` for every name of :data:`STATISTICS` (e.g.
        from :func:`~simroad.experiments.realism.photo_statistics`).
    source : str
        Where the reference comes from (kept in the result).
    start : CameraProfile, optional
        Where the search starts and what it keeps of the fields it does not fit
        (default: simroad's default profile).
    fit : sequence of str
        Fields to fit (default :data:`FIT_PARAMETERS`): names of
        :data:`~simroad.camera.profile.PROFILE_RANGES` or ``sky_brightness``.
    scenarios, seeds, frames
        The worlds of every evaluation: one episode per scenario and seed,
        ``frames`` frames each in [1, 50] (policy steps 5, 10, ...).
    max_evaluations : int
        Renders of the worlds at most, in [1, 10000] (the first, with ``start``, among them).
    max_replays : int
        Profiles scored from the recordings at most, in [1, 100000].
    workers : int, optional
        Processes that render the worlds, threads that expose them (default: the cores
        this process may use).
    env_options : dict, optional
        Further RoadCam keywords for every environment (camera size, ...); not
        ``scenario``, ``noise``, ``severity`` or ``camera_profile``.
    progress : bool
        Show a progress bar over the renders.

    Returns
    -------
    CalibrationResult
    """
    ref = {s: _finite(reference.get(s, ())) for s in STATISTICS}
    scenarios, worlds = check_frame_protocol(scenarios=scenarios, seeds=seeds, noise="clear", severity=0.0)
    frames = check_int_in_range("frames", frames, 1, 50)
    max_evaluations = check_int_in_range("max_evaluations", max_evaluations, 1, 10_000)
    max_replays = check_int_in_range("max_replays", max_replays, 1, 100_000)
    workers = default_workers() if workers is None else check_int_in_range("workers", workers, 1, 256)
    start = _check_start(start)
    names = check_fit(fit)
    options = check_env_options(
        env_options, ("scenario", "noise", "severity", "camera_profile"),
        "set by the calibration (clear frames of its scenarios with the profile it tries); drop them.",
    )  # fmt: skip
    objective = CalibrationObjective(ref)  # refuses a reference without values before any rendering
    search = BlockSearch(
        objective,
        lambda profile: record_worlds(
            profile,
            scenarios=scenarios,
            seeds=worlds,
            frames=frames,
            every=_EVERY,
            env_options=options,
            workers=workers,
        ),
        lambda recordings, profile: replay_statistics(recordings, profile, env_options=options, threads=workers),
        names,
        start,
        max_evaluations,
        max_replays,
        progress,
    )
    try:
        search.run()
    finally:
        search.bar.close()
    best, best_values = search.best
    start_objective, start_values = search.first
    return CalibrationResult(
        profile=search.profile,
        start=start,
        objective=best,
        start_objective=start_objective,
        ks=ks_distances(best_values, ref),
        start_ks=ks_distances(start_values, ref),
        fitted=names,
        evaluations=search.replays,
        renders=search.renders,
        frames=int(best_values["road_V"].size),
        photos=int(ref["road_V"].size),
        source=source,
    )


def _check_start(start: Any) -> CameraProfile:
    if start is None:
        return CameraProfile()
    if not isinstance(start, CameraProfile):
        raise InvalidParameterError(f"start: expected a CameraProfile or None, got {type(start).__name__}.")
    return start


def calibrate_from_photos(
    photos: str | os.PathLike,
    masks: str | os.PathLike,
    *,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
    **options: Any,
) -> CalibrationResult:
    """:func:`calibrate_profile` against the statistics of a folder of photographs and
    their road masks (:func:`~simroad.experiments.realism.photo_statistics`, which
    says what it refuses, and how ``road_value`` and ``road_colour`` read the masks);
    ``options`` are :func:`calibrate_profile`'s."""
    values, source = photo_statistics(photos, masks, road_value=road_value, road_colour=road_colour)
    return calibrate_profile(values, source=source, **options)


def _cell(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.3f}"


def _shown(value: Any) -> str:
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(f"{v:.3g}" for v in value) + "]"
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def format_calibration(result: CalibrationResult) -> str:
    """A plain-text report: the fitted fields (start -> fitted) and, per statistic,
    the KS distance to the photos with the start profile and with the fitted one."""
    lines = ["field                 start       fitted"]
    for name in result.fitted:
        a, b = getattr(result.start, name), getattr(result.profile, name)
        lines.append(f"{name:<20}  {_shown(a):>10}  {_shown(b):>11}")
    lines += ["", "statistic              KS start  KS fitted"]
    for s in STATISTICS:
        lines.append(f"{s:<20}  {_cell(result.start_ks[s]):>10}  {_cell(result.ks[s]):>9}")
    lines.append(
        f"objective (mean quantile miss in standard errors): {result.start_objective:.3f} -> "
        f"{result.objective:.3f}; {result.evaluations} profiles of {result.frames} frames each "
        f"({result.renders} renders); "
        f"{result.photos} photographs ({result.source})"
    )
    return "\n".join(lines)


def write_calibration(result: CalibrationResult, out: str | os.PathLike) -> Path:
    """Write the fitted profile to ``out`` (a ``.toml`` file) with
    :func:`~simroad.camera.profile.save_profile`, a comment header saying what it was
    fitted to and how well; ``load_profile`` and ``camera_profile=`` read it."""
    path = check_output_file("out", out, suffixes=(".toml",))
    ks = ", ".join(f"{s} {_cell(result.ks[s])}" for s in STATISTICS)
    comment = "\n".join(
        [
            "Written by simroad calibrate: a camera profile fitted to photographs.",
            f"photos: {result.source}",
            f"frames per evaluation: {result.frames}; evaluations: {result.evaluations}; renders: {result.renders}; "
            f"fitted: {', '.join(result.fitted)}",
            f"objective: {result.start_objective:.4f} (default profile) -> {result.objective:.4f}",
            f"KS to the photos: {ks}",
        ]
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    save_profile(result.profile, path, comment=comment)
    return path
