"""Does each filter earn its place? The detector with and without a filter on the
weather it is meant for, on held-out worlds.

``filter_effect("shadow", ["shadow"])`` renders ``frames`` frames of every scenario
for every seed under the noise (severity 0.7 by default) with
:func:`~simroad.experiments.frames.collect_frames`, runs the detector without filters
and with the given ones, and pools FNR and FPR (paper eqs. 32-33) over the camera's
ground pixels (``valid``): the sky is never road, and an overcast sky would otherwise
dominate the FPR. :func:`filter_effect_table` scores the protocol -- each
filter on its matching noise, and all filters on every noise -- rendering each noise
once.

Each row also holds the paired difference of FNR + FPR, with minus without, and its
95 % interval (:func:`~simroad.experiments.stats.paired_pooled_difference`): the
frames of one episode (a scenario in one world) are correlated, so the bootstrap
resamples episodes, the same ones for both detectors, and pools their pixel counts
again. ``resolved`` says the interval lies below 0.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.names import HELD_OUT_SEEDS
from simroad.core.validation import check_choice, check_in_range, check_int_in_range
from simroad.detector import RoadDetector
from simroad.detector.registry import predict_alone
from simroad.envs import SCENARIO_NAMES
from simroad.errors import InvalidParameterError
from simroad.experiments.frames import FrameSet, collect_frames
from simroad.experiments.stats import COUNT_KEYS, paired_pooled_difference
from simroad.filters import FILTER_REGISTRY, FILTERS, check_filters
from simroad.metrics.mask import MaskScore, rates_from_counts

__all__ = ["FILTER_NOISE", "filter_effect", "filter_effect_table", "format_filter_effect"]

#: The weather each filter is meant to remove (the protocol of :func:`filter_effect_table`).
FILTER_NOISE = {name: spec.weathers for name, spec in FILTER_REGISTRY.items()}
_NOISES = tuple(noise for weathers in FILTER_NOISE.values() for noise in weathers)

DetectorFactory = Callable[[tuple[str, ...]], object]


def _default_factory(filters: tuple[str, ...]):

    return RoadDetector.pretrained(filters=filters)


def _render(
    noise: str, seeds: tuple[int, ...], frames: int, severity: float, every: int, cache: dict, profile: Any = None
) -> FrameSet:
    """Frames of every scenario and seed under ``noise``, rendered once per cache."""
    key = (noise, seeds, frames, severity, every, profile)
    if key not in cache:
        cache[key] = collect_frames(
            scenarios=SCENARIO_NAMES, seeds=seeds, frames_per_seed=frames, every=every,
            noise=noise, severity=severity, env_options={} if profile is None else {"camera_profile": profile},
        )  # fmt: skip
    return cache[key]


def _episodes(frames: FrameSet) -> list[tuple[str, int]]:
    """The episode (scenario, seed) of each frame, from ``frames.source``."""
    if len(frames.source) != len(frames.images):
        raise InvalidParameterError(
            f"frames.source: expected one (scenario, seed, step) per frame to tell the episodes apart, "
            f"got {len(frames.source)} for {len(frames.images)} frames."
        )
    return [(scenario, int(seed)) for scenario, seed, _ in frames.source]


def _score(detector, frames: FrameSet) -> tuple[dict[str, float], np.ndarray]:
    """Pooled ground FNR and FPR of ``detector`` on ``frames``, and the pixel counts
    per episode (rows in order of first appearance, columns ``COUNT_KEYS``)."""
    scores: dict[tuple[str, int], MaskScore] = {}
    for episode, image, gt, valid in zip(_episodes(frames), frames.images, frames.masks, frames.valid):
        scores.setdefault(episode, MaskScore()).update(predict_alone(detector, image), gt, valid=valid)
    counts = np.array([[getattr(s, k) for k in COUNT_KEYS] for s in scores.values()], dtype=np.int64)
    counts = counts.reshape(-1, len(COUNT_KEYS))
    pooled = rates_from_counts(*(int(c) for c in counts.sum(axis=0)))
    return {"fnr": pooled["fnr"], "fpr": pooled["fpr"]}, counts


def _check_protocol(
    seeds: Iterable[int], frames: int, severity: float, every: int
) -> tuple[tuple[int, ...], int, float, int]:
    worlds = tuple(int(s) for s in seeds)
    if not worlds:
        raise InvalidParameterError("seeds: expected at least one seed (held-out worlds are >= 100), got none.")
    frames = check_int_in_range("frames", frames, 1, 10_000)
    severity = check_in_range("severity", severity, 0.0, 1.0)
    every = check_int_in_range("every", every, 1, 1000)
    return worlds, frames, severity, every


def filter_effect(
    noise: str,
    filters: Sequence[str],
    *,
    seeds: Iterable[int] = HELD_OUT_SEEDS,
    frames: int = 20,
    severity: float = 0.7,
    every: int = 4,
    detector_factory: DetectorFactory | None = None,
    cache: dict | None = None,
    camera_profile: CameraProfile | str | os.PathLike | None = None,
) -> dict:
    """Score the detector without filters and with ``filters`` on frames under ``noise``.

    Parameters
    ----------
    noise : str
        One of ``"shadow"``, ``"rain"``, ``"snow"``, ``"glare"`` (or any spec
        :func:`~simroad.noise.parse_noise` accepts, e.g. ``"rain+glare"``).
    filters : sequence of str
        Subset of :data:`simroad.filters.FILTERS` for the "with" run.
    seeds : iterable of int
        Worlds; one episode per scenario (all of them) and seed. The shipped model
        was trained on worlds 0-15 (``simroad train-detector``), so keep these >= 100.
    frames : int
        Frames kept per episode.
    severity : float
        Noise severity in [0, 1].
    every : int
        Policy steps between kept frames.
    detector_factory : callable, optional
        ``filters -> fitted detector``; default :meth:`RoadDetector.pretrained`.
    cache : dict, optional
        Rendered frames keyed by protocol, reused across calls (pass the same dict).
    camera_profile : CameraProfile, dict or path, optional
        The camera of every frame (RoadCam's ``camera_profile``, e.g. a TOML file
        from ``simroad calibrate``); None is simroad's default profile.

    Returns
    -------
    dict
        ``noise``, ``filters`` (tuple), ``frames`` (total), ``episodes`` (scenarios x
        seeds), ``without`` and ``with`` (each ``{"fnr", "fpr"}``, pooled over the
        ground pixels, fractions); ``diff``, ``diff_lo``, ``diff_hi``: FNR + FPR with
        minus without, as a fraction (-0.05: five points lower with the filters), and
        its 95 % interval from a bootstrap of the episodes in pairs (NaN with one
        episode; :func:`~simroad.experiments.stats.paired_pooled_difference`);
        ``better`` -- True when FNR + FPR is lower with the filters -- and
        ``resolved`` -- True when the whole interval is below 0.
    """
    worlds, frames, severity, every = _check_protocol(seeds, frames, severity, every)
    names = check_filters(filters)
    if not names:
        raise InvalidParameterError("filters: expected at least one filter to compare against none, got none.")
    factory = detector_factory or _default_factory
    profile = None if camera_profile is None else resolve_profile(camera_profile)
    frame_set = _render(noise, worlds, frames, severity, every, {} if cache is None else cache, profile)
    without, counts_off = _score(factory(()), frame_set)
    with_, counts_on = _score(factory(names), frame_set)
    diff, lo, hi = paired_pooled_difference(counts_on, counts_off)
    return {
        "noise": noise, "filters": names, "frames": len(frame_set.images), "episodes": len(counts_on),
        "without": without, "with": with_, "diff": diff, "diff_lo": lo, "diff_hi": hi,
        "better": with_["fnr"] + with_["fpr"] < without["fnr"] + without["fpr"],
        "resolved": bool(hi < 0.0),  # NaN (one episode) compares False
    }  # fmt: skip


def filter_effect_table(
    *,
    seeds: Iterable[int] = HELD_OUT_SEEDS,
    frames: int = 20,
    severity: float = 0.7,
    every: int = 4,
    noises: Sequence[str] = _NOISES,
    detector_factory: DetectorFactory | None = None,
    cache: dict | None = None,
    camera_profile: CameraProfile | str | os.PathLike | None = None,
) -> list[dict]:
    """The protocol: each filter on its matching noise, then all filters on
    each noise. One :func:`filter_effect` row per case, each noise rendered once.

    ``noises`` restricts the rows to some of ``shadow``, ``rain``, ``snow``,
    ``glare`` (for quick checks); the other parameters are those of
    :func:`filter_effect`.
    """
    for n in noises:
        check_choice("noises", n, _NOISES)
    cache = {} if cache is None else cache
    cases: list[tuple[str, tuple[str, ...]]] = [(n, (f,)) for f, ns in FILTER_NOISE.items() for n in ns if n in noises]
    cases += [(n, FILTERS) for n in _NOISES if n in noises]
    worlds = tuple(seeds)
    return [
        filter_effect(n, f, seeds=worlds, frames=frames, severity=severity, every=every,
                      detector_factory=detector_factory, cache=cache, camera_profile=camera_profile)
        for n, f in cases
    ]  # fmt: skip


def _format_diff(diff: float, lo: float, hi: float) -> str:
    """``diff [lo, hi]`` in points; ``diff (n=1)`` without an interval."""
    if not math.isfinite(diff):
        return "–"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{100 * diff:+.2f} (n=1)"
    return f"{100 * diff:+.2f} [{100 * lo:+.2f}, {100 * hi:+.2f}]"


def format_filter_effect(rows: Sequence[dict]) -> str:
    """A plain-text table of :func:`filter_effect_table` rows, rates in percent.

    ``Δ [95 % CI]`` is FNR + FPR with minus without in points, with its interval
    (``(n=1)``: one episode, no interval); ``better`` is ``yes`` when the difference
    is below 0 and ``NO`` otherwise, ``resolved`` ``yes`` when its whole interval is.
    """
    head = (
        f"{'noise':<7} {'filters':<22} {'frames':>6} {'FNR off':>8} {'FPR off':>8} {'FNR on':>8} {'FPR on':>8}  "
        f"{'Δ [95 % CI]':<24} better  resolved"
    )
    lines = [head]
    for r in rows:
        a, b = r["without"], r["with"]
        diff = _format_diff(r["diff"], r["diff_lo"], r["diff_hi"])
        lines.append(
            f"{r['noise']:<7} {'+'.join(r['filters']):<22} {r['frames']:>6} {100 * a['fnr']:>8.2f} "
            f"{100 * a['fpr']:>8.2f} {100 * b['fnr']:>8.2f} {100 * b['fpr']:>8.2f}  {diff:<24} "
            f"{'yes' if r['better'] else 'NO':<6}  {'yes' if r['resolved'] else 'no'}"
        )
    return "\n".join(lines)
