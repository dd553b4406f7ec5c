"""Does each filter earn its place? The detector with and without a filter on the
weather it is meant for, on held-out worlds.

``filter_effect("shadow", ["shadow"])`` renders ``frames`` frames of every scenario
for every seed under the noise (severity 0.7 by default) with
:func:`~simroad.experiments.frames.collect_frames`, runs the detector without filters
and with the given ones, and pools FNR and FPR (paper eqs. 32-33) over the camera's
ground pixels (``valid``): the sky is never road, and an overcast sky would otherwise
dominate the FPR. :func:`filter_effect_table` scores the issue's protocol -- each
filter on its matching noise, and all filters on every noise -- rendering each noise
once.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from simroad._validation import SimroadError, check_choice, check_in_range, check_int_in_range
from simroad.envs import SCENARIO_NAMES
from simroad.experiments.frames import FrameSet, collect_frames
from simroad.filters import FILTER_REGISTRY, FILTERS, check_filters
from simroad.metrics.mask import MaskScore

__all__ = ["FILTER_NOISE", "filter_effect", "filter_effect_table", "format_filter_effect"]

#: The weather each filter is meant to remove (the issue's protocol).
FILTER_NOISE = {name: spec.weathers for name, spec in FILTER_REGISTRY.items()}
_NOISES = tuple(noise for weathers in FILTER_NOISE.values() for noise in weathers)

DetectorFactory = Callable[[tuple[str, ...]], object]


def _default_factory(filters: tuple[str, ...]):
    from simroad.detector import RoadDetector

    return RoadDetector.pretrained(filters=filters)


def _render(noise: str, seeds: tuple[int, ...], frames: int, severity: float, every: int, cache: dict) -> FrameSet:
    """Frames of every scenario and seed under ``noise``, rendered once per cache."""
    key = (noise, seeds, frames, severity, every)
    if key not in cache:
        cache[key] = collect_frames(
            scenarios=SCENARIO_NAMES, seeds=seeds, frames_per_seed=frames, every=every,
            noise=noise, severity=severity,
        )  # fmt: skip
    return cache[key]


def _score(detector, frames: FrameSet) -> dict[str, float]:
    score = MaskScore()
    for image, gt, valid in zip(frames.images, frames.masks, frames.valid):
        score.update(detector.predict(image), gt, valid=valid)
    pooled = score.pooled()
    return {"fnr": pooled["fnr"], "fpr": pooled["fpr"]}


def _check_protocol(
    seeds: Iterable[int], frames: int, severity: float, every: int
) -> tuple[tuple[int, ...], int, float, int]:
    worlds = tuple(int(s) for s in seeds)
    if not worlds:
        raise SimroadError("seeds: expected at least one seed (held-out worlds are >= 100), got none.")
    frames = check_int_in_range("frames", frames, 1, 10_000)
    severity = check_in_range("severity", severity, 0.0, 1.0)
    every = check_int_in_range("every", every, 1, 1000)
    return worlds, frames, severity, every


def filter_effect(
    noise: str,
    filters: Sequence[str],
    *,
    seeds: Iterable[int] = range(100, 105),
    frames: int = 20,
    severity: float = 0.7,
    every: int = 4,
    detector_factory: DetectorFactory | None = None,
    cache: dict | None = None,
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

    Returns
    -------
    dict
        ``noise``, ``filters`` (tuple), ``frames`` (total), ``without`` and ``with``
        (each ``{"fnr", "fpr"}``, pooled over the ground pixels, fractions) and
        ``better`` -- True when FNR + FPR is lower with the filters.
    """
    worlds, frames, severity, every = _check_protocol(seeds, frames, severity, every)
    names = check_filters(filters)
    if not names:
        raise SimroadError("filters: expected at least one filter to compare against none, got none.")
    factory = detector_factory or _default_factory
    frame_set = _render(noise, worlds, frames, severity, every, {} if cache is None else cache)
    without = _score(factory(()), frame_set)
    with_ = _score(factory(names), frame_set)
    return {
        "noise": noise, "filters": names, "frames": len(frame_set.images),
        "without": without, "with": with_,
        "better": with_["fnr"] + with_["fpr"] < without["fnr"] + without["fpr"],
    }  # fmt: skip


def filter_effect_table(
    *,
    seeds: Iterable[int] = range(100, 105),
    frames: int = 20,
    severity: float = 0.7,
    every: int = 4,
    noises: Sequence[str] = _NOISES,
    detector_factory: DetectorFactory | None = None,
    cache: dict | None = None,
) -> list[dict]:
    """The issue's protocol: each filter on its matching noise, then all filters on
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
                      detector_factory=detector_factory, cache=cache)
        for n, f in cases
    ]  # fmt: skip


def format_filter_effect(rows: Sequence[dict]) -> str:
    """A plain-text table of :func:`filter_effect_table` rows, rates in percent."""
    head = (
        f"{'noise':<7} {'filters':<22} {'frames':>6} {'FNR off':>8} {'FPR off':>8} {'FNR on':>8} {'FPR on':>8}  better"
    )
    lines = [head]
    for r in rows:
        a, b = r["without"], r["with"]
        lines.append(
            f"{r['noise']:<7} {'+'.join(r['filters']):<22} {r['frames']:>6} {100 * a['fnr']:>8.2f} "
            f"{100 * a['fpr']:>8.2f} {100 * b['fnr']:>8.2f} {100 * b['fpr']:>8.2f}  {'yes' if r['better'] else 'NO'}"
        )
    return "\n".join(lines)
