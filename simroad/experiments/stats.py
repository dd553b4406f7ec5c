"""Intervals and paired comparisons for a sweep's report.

Means of bounded per-episode quantities (driving score, IoU, FNR, FPR, off-road
fraction, lateral RMSE) get a **percentile bootstrap** interval of the mean
(:func:`scipy.stats.bootstrap`, ``method="percentile"``, :data:`N_RESAMPLES`
resamples from ``numpy.random.default_rng(SEED)``). Every resampled mean lies between
the smallest and the largest value, so the interval never leaves the quantity's range
(an off-road fraction's interval stays in [0, 1]). The values are sorted first, so
the interval depends on the values only, not on the order the episodes finished in;
with the fixed seed the same values give the same interval, bit for bit.

Rates of yes/no events (collisions) get the exact binomial **Clopper-Pearson**
interval (:meth:`scipy.stats.binomtest(...).proportion_ci <scipy.stats.binomtest>`),
which lies in [0, 1] by construction and exists for one episode too.

Degenerate samples, said plainly rather than hidden:

- no value: mean, low and high are NaN;
- one value: the mean is the value, low and high are NaN (one episode gives no
  interval; the report shows ``(n=1)``);
- all values equal: low = high = the mean (every resample has that mean; the seeds
  showed no spread, which is not a proof that there is none).

With few episodes the percentile bootstrap is too narrow: it cannot show more spread
than the episodes had (three values give about their minimum and maximum). More
seeds, not another formula, resolve a difference.

**Paired comparisons** (:func:`paired_differences`): two settings driven in the same
world with the same seed (same scenario, noise, severity, seed and detector) are a
pair; the interval of the mean paired difference bootstraps the pairs.

**Pooled rates in pairs** (:func:`paired_pooled_difference`): FNR + FPR pooled over
the pixels of many episodes (a ratio of sums, not a mean of per-episode rates), one
setting minus another scored on the same frames. The frames of one episode are
correlated, so the unit of the bootstrap is the episode (the world): each resample
draws episodes with replacement, the same ones for both settings, and pools their
pixel counts again. Same percentile bootstrap, resamples and seed as
:func:`mean_interval`; no episode gives NaN, one episode no interval, identical
counts in every pair ``lo = hi = 0``.
"""

from __future__ import annotations

import inspect
import math
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from simroad.core.validation import check_in_range, check_int_in_range
from simroad.errors import InvalidParameterError
from simroad.filters.pipeline import FILTER_NAMES, format_filters

__all__ = [
    "ALL_FILTERS",
    "CONFIDENCE",
    "COUNT_KEYS",
    "N_RESAMPLES",
    "PAIRED_METRICS",
    "SEED",
    "detectors",
    "filter_order",
    "fnr_plus_fpr",
    "head_to_head_label",
    "mean_interval",
    "paired_differences",
    "paired_pooled_difference",
    "proportion_interval",
]

#: Bootstrap resamples per interval (scipy's default).
N_RESAMPLES = 9999
#: Two-sided confidence level of every interval.
CONFIDENCE = 0.95
#: Seed of the bootstrap's generator (fixed: the same results give the same report).
SEED = 0
#: Record keys compared in pairs (differences ``setting - baseline``).
PAIRED_METRICS = ("driving_score", "offroad_fraction", "fnr", "fpr")
#: The filter set with every filter on, as records spell it.
ALL_FILTERS = format_filters(FILTER_NAMES)
#: A pair's world: records that match on these keys (and the comparison's group) are paired.
_PAIR_KEY = ("scenario", "seed")
#: Confusion counts in the order of the columns of per-episode count arrays.
COUNT_KEYS = ("tp", "fp", "fn", "tn")


def _finite(values: Iterable[Any]) -> np.ndarray:
    return np.asarray(
        [float(v) for v in values if v is not None and not isinstance(v, str) and math.isfinite(float(v))], dtype=float
    )


def _generator_keyword() -> str:
    """scipy >= 1.15 names the bootstrap's generator ``rng``; older versions ``random_state``."""
    from scipy import stats

    return "rng" if "rng" in inspect.signature(stats.bootstrap).parameters else "random_state"


def _check_bootstrap(confidence: float, n_resamples: int, seed: int) -> None:
    check_in_range("confidence", confidence, 0.0, 1.0, low_inclusive=False, high_inclusive=False)
    check_int_in_range("n_resamples", n_resamples, 1, 10**7)
    check_int_in_range("seed", seed, 0, 2**63 - 1)


def _percentile_bootstrap(
    sample: np.ndarray,
    statistic: Callable[..., np.ndarray],
    *,
    confidence: float,
    n_resamples: int,
    seed: int,
) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``statistic`` over one sample (the module's
    convention); ``statistic(resampled, axis=-1)`` is vectorized over leading axes."""
    from scipy import stats

    res = stats.bootstrap(
        (sample,),
        statistic,
        n_resamples=n_resamples,
        confidence_level=confidence,
        method="percentile",
        vectorized=True,
        **{_generator_keyword(): np.random.default_rng(seed)},
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def mean_interval(
    values: Iterable[Any], *, confidence: float = CONFIDENCE, n_resamples: int = N_RESAMPLES, seed: int = SEED
) -> tuple[float, float, float]:
    """Mean of ``values`` and the percentile-bootstrap interval of the mean.

    Parameters
    ----------
    values : iterable of float
        Per-episode values; None, NaN and infinities are left out.
    confidence : float
        Two-sided confidence level in (0, 1).
    n_resamples : int
        Bootstrap resamples.
    seed : int
        Seed of ``numpy.random.default_rng`` drawing the resamples.

    Returns
    -------
    mean, low, high : float
        See the module docstring for no value (all NaN), one value (low and high
        NaN) and equal values (low = high = mean).
    """
    _check_bootstrap(confidence, n_resamples, seed)
    v = np.sort(_finite(values))
    if len(v) == 0:
        return math.nan, math.nan, math.nan
    mean = float(v.mean())
    if len(v) == 1:
        return mean, math.nan, math.nan
    if v[0] == v[-1]:
        return mean, mean, mean
    lo, hi = _percentile_bootstrap(v, np.mean, confidence=confidence, n_resamples=n_resamples, seed=seed)
    # the resampled means lie in [min, max]; clip only the last-bit rounding of the mean
    return mean, max(lo, float(v[0])), min(hi, float(v[-1]))


def proportion_interval(flags: Iterable[Any], *, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Rate of ``flags`` (e.g. ``collided`` per episode) and its Clopper-Pearson interval.

    Parameters
    ----------
    flags : iterable of bool or 0/1
        One per episode; None and NaN are left out.
    confidence : float
        Two-sided confidence level in (0, 1).

    Returns
    -------
    rate, low, high : float
        ``k / n`` and the exact binomial interval; all NaN without a flag.
    """
    check_in_range("confidence", confidence, 0.0, 1.0, low_inclusive=False, high_inclusive=False)
    v = _finite(flags)
    if len(v) and not np.isin(v, (0.0, 1.0)).all():
        bad = next(x for x in v if x not in (0.0, 1.0))
        raise InvalidParameterError(f"flags: expected true/false (or 0/1) per episode, got {bad!r}.")
    if len(v) == 0:
        return math.nan, math.nan, math.nan
    from scipy import stats

    k, n = int(v.sum()), len(v)
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
    return k / n, float(ci.low), float(ci.high)


def fnr_plus_fpr(counts: Any) -> np.ndarray:
    """FNR + FPR (paper eqs. 32-33) of confusion counts.

    Parameters
    ----------
    counts : array_like, (..., 4)
        Counts in the order of :data:`COUNT_KEYS` (``tp, fp, fn, tn``), e.g. summed
        over the frames of some episodes.

    Returns
    -------
    ndarray, (...)
        ``FN / (TP + FN) + FP / (FP + TN)`` as a fraction in [0, 2]; NaN where a
        denominator is 0.
    """
    tp, fp, fn, tn = np.moveaxis(np.asarray(counts, dtype=float), -1, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return fn / (tp + fn) + fp / (fp + tn)


def _episode_counts(name: str, counts: Any) -> np.ndarray:
    """``counts`` as an int64 array (episodes, 4), or a SimroadError naming ``name``."""
    try:
        a = np.asarray(counts, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(
            f"{name}: expected per-episode counts (episodes x {', '.join(COUNT_KEYS)}): {exc}"
        ) from None
    if a.size == 0:
        a = a.reshape(0, len(COUNT_KEYS))
    if a.ndim != 2 or a.shape[1] != len(COUNT_KEYS):
        raise InvalidParameterError(
            f"{name}: expected per-episode counts of shape (episodes, 4) in the order "
            f"{', '.join(COUNT_KEYS)}, got shape {a.shape}."
        )
    bad = ~(np.isfinite(a) & (a >= 0) & (a == np.round(a)))
    if bad.any():
        raise InvalidParameterError(f"{name}: expected non-negative integer pixel counts, got {float(a[bad][0])!r}.")
    return a.astype(np.int64)


def paired_pooled_difference(
    setting: Any,
    baseline: Any,
    *,
    confidence: float = CONFIDENCE,
    n_resamples: int = N_RESAMPLES,
    seed: int = SEED,
) -> tuple[float, float, float]:
    """FNR + FPR pooled over episodes, ``setting - baseline``, with the interval of a
    bootstrap that resamples the episodes in pairs.

    Row ``i`` of ``setting`` and of ``baseline`` are the pixel counts of the same
    episode (the same frames) scored two ways. The difference is that of the pooled
    rates: each setting's counts are summed over the episodes, then
    :func:`fnr_plus_fpr` is taken (a ratio of sums). Each bootstrap resample draws
    episodes with replacement, the same ones for both settings (the pairing), and
    pools their counts again; the interval is the percentile interval of the
    resampled differences (:func:`mean_interval`'s convention, resamples and seed).
    The episodes are sorted by their counts first, so the interval does not depend
    on the order they were given in.

    Parameters
    ----------
    setting, baseline : array_like, (episodes, 4)
        Non-negative integer pixel counts per episode, columns :data:`COUNT_KEYS`.
    confidence : float
        Two-sided confidence level in (0, 1).
    n_resamples : int
        Bootstrap resamples.
    seed : int
        Seed of ``numpy.random.default_rng`` drawing the resamples.

    Returns
    -------
    diff, low, high : float
        Fractions (a difference of -0.05 is 5 points lower with ``setting``). No
        episode: all NaN; one episode, or a pooled rate undefined (no road or no
        non-road pixel): low and high NaN; every episode's counts equal in both:
        ``0, 0, 0``.
    """
    _check_bootstrap(confidence, n_resamples, seed)
    a, b = _episode_counts("setting", setting), _episode_counts("baseline", baseline)
    if len(a) != len(b):
        raise InvalidParameterError(
            f"setting, baseline: expected the same episodes in both, got {len(a)} and {len(b)} rows."
        )
    if len(a) == 0:
        return math.nan, math.nan, math.nan
    diff = float(fnr_plus_fpr(a.sum(axis=0)) - fnr_plus_fpr(b.sum(axis=0)))
    if len(a) == 1 or not math.isfinite(diff):
        return diff, math.nan, math.nan
    if np.array_equal(a, b):
        return diff, diff, diff
    order = np.lexsort(np.hstack([a, b]).T[::-1])
    a, b = a[order], b[order]

    def resampled(episodes: np.ndarray, axis: int = -1) -> np.ndarray:
        # episodes: (..., n) indices drawn with replacement (scipy's paired=True does the same)
        return fnr_plus_fpr(a[episodes].sum(axis=-2)) - fnr_plus_fpr(b[episodes].sum(axis=-2))

    lo, hi = _percentile_bootstrap(
        np.arange(len(a)), resampled, confidence=confidence, n_resamples=n_resamples, seed=seed
    )
    return diff, lo, hi


def detectors(records: Sequence[dict]) -> list[str]:
    """The detectors that drove (by name), in a fixed order, ``paper`` first."""
    return sorted(
        {r.get("detector", "") for r in records if r["driver"] == "detector"}, key=lambda d: (d != "paper", d)
    )


def filter_order(filters: Iterable[str]) -> list[str]:
    """Filter sets in report order: ``none`` first, then single sets, all filters last."""
    return sorted(set(filters), key=lambda f: (f != "none", f == ALL_FILTERS, f))


def _by_world(records: Iterable[dict]) -> dict[tuple, dict]:
    """Records by their world (scenario, seed): the first of each."""
    out: dict[tuple, dict] = {}
    for r in records:
        out.setdefault(tuple(r[k] for k in _PAIR_KEY), r)
    return out


def _paired_row(a: dict[tuple, dict], b: dict[tuple, dict], metrics: Sequence[str], **label: Any) -> dict:
    worlds = sorted(set(a) & set(b), key=lambda w: tuple(map(str, w)))
    row: dict[str, Any] = {**label, "pairs": len(worlds)}
    for m in metrics:
        diffs = [float(a[w][m]) - float(b[w][m]) for w in worlds]
        mean, lo, hi = mean_interval(diffs)
        row[f"{m}_diff"], row[f"{m}_diff_lo"], row[f"{m}_diff_hi"] = mean, lo, hi
    return row


def paired_differences(records: Sequence[dict], *, metrics: Sequence[str] = PAIRED_METRICS) -> list[dict]:
    """Each filter set (and the oracle) against no filters, in pairs of the same world.

    For each detector, noise and severity, and each filter set ``f`` other than
    ``none``: the records of ``f`` and of ``none`` with the same scenario and seed
    are a pair; the row holds the number of pairs and, per metric, the mean of the
    paired differences ``f - none`` with its bootstrap interval (resampling pairs;
    :func:`mean_interval`: NaN with fewer than two pairs). The oracle against the
    detector without filters comes last (``setting`` ``oracle``). One row pools
    every scenario (``scenario`` ``all``), then one row per scenario. With more than
    one detector, each detector after the first (``paper`` when it ran) is then
    compared with the first at every filter set both ran: ``detector`` is
    ``"mine − paper"`` (:func:`head_to_head_label`), ``baseline`` the first detector.
    Failed episodes (``error`` set) are left out; a metric's difference uses the pairs
    where both values are finite.

    Parameters
    ----------
    records : sequence of dict
        Episode records (rows of ``results.jsonl``).
    metrics : sequence of str
        Record keys to compare.

    Returns
    -------
    list of dict
        Keys ``detector``, ``noise``, ``severity``, ``scenario``, ``setting`` (a
        filter set or ``oracle``), ``baseline`` (``none``, or the first detector),
        ``comparison`` (``filters``, ``oracle`` or ``detectors``), ``pairs``, and for
        each metric ``<metric>_diff``, ``<metric>_diff_lo``, ``<metric>_diff_hi``.
    """
    ok = [r for r in records if not r.get("error")]
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in ok:
        groups[(r["noise"], r["severity"])].append(r)
    rows = []
    for noise, severity in sorted(groups, key=lambda c: (c[0] != "clear", c[0], c[1])):
        rs = groups[(noise, severity)]
        oracle = [r for r in rs if r["driver"] == "oracle"]
        for det in detectors(rs):
            mine = [r for r in rs if r["driver"] == "detector" and r.get("detector", "") == det]
            none = [r for r in mine if r["filters"] == "none"]
            if not none:
                continue
            settings = [(f, [r for r in mine if r["filters"] == f]) for f in filter_order(r["filters"] for r in mine)]
            settings = [(f, s) for f, s in settings if f != "none"] + ([("oracle", oracle)] if oracle else [])
            for setting, recs in settings:
                label = dict(detector=det, noise=noise, severity=severity, setting=setting, baseline="none",
                             comparison="oracle" if setting == "oracle" else "filters")  # fmt: skip
                rows += _per_scenario(recs, none, (r["scenario"] for r in mine), metrics, label)
        rows += _head_to_head(rs, noise, severity, metrics)
    return rows


#: The identifying keys of a paired row, in their column order.
_ROW_LABEL = ("detector", "noise", "severity", "scenario", "setting", "baseline", "comparison")


def _per_scenario(
    recs: list[dict], ref: list[dict], scenarios: Iterable[str], metrics: Sequence[str], label: dict
) -> list[dict]:
    """The paired rows of ``recs`` against ``ref``: pooled over scenarios (``all``), then
    one per scenario of ``scenarios``."""
    rows = []
    for scenario in ["all", *sorted(set(scenarios))]:
        a = _by_world(r for r in recs if scenario in ("all", r["scenario"]))
        b = _by_world(r for r in ref if scenario in ("all", r["scenario"]))
        full = {**label, "scenario": scenario}
        rows.append(_paired_row(a, b, metrics, **{k: full[k] for k in _ROW_LABEL}))
    return rows


def head_to_head_label(detector: str, baseline: str) -> str:
    """The ``detector`` of a head-to-head row of :func:`paired_differences`."""
    return f"{detector} − {baseline}"


def _head_to_head(rs: list[dict], noise: str, severity: float, metrics: Sequence[str]) -> list[dict]:
    """Each detector after the first (``paper`` when it ran) against the first, at every
    filter set both ran, in pairs of the same world."""
    dets = detectors(rs)
    if len(dets) < 2:
        return []
    of = {d: [r for r in rs if r["driver"] == "detector" and r.get("detector", "") == d] for d in dets}
    base, rows = dets[0], []
    for det in dets[1:]:
        both = [f for f in filter_order(r["filters"] for r in of[det]) if any(r["filters"] == f for r in of[base])]
        for setting in both:
            label = dict(detector=head_to_head_label(det, base), noise=noise, severity=severity, setting=setting,
                         baseline=base, comparison="detectors")  # fmt: skip
            mine = [r for r in of[det] if r["filters"] == setting]
            ref = [r for r in of[base] if r["filters"] == setting]
            rows += _per_scenario(mine, ref, (r["scenario"] for r in of[det]), metrics, label)
    return rows
