"""Report statistics: bootstrap and Clopper-Pearson intervals against independent
references and cases worked by hand; pairs matched to the right episodes; pooled rates
bootstrapped by episode in pairs."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from scipy import stats

from simroad import SimroadError
from simroad.experiments.stats import (
    ALL_FILTERS,
    N_RESAMPLES,
    SEED,
    fnr_plus_fpr,
    mean_interval,
    paired_differences,
    paired_pooled_difference,
    proportion_interval,
)
from simroad.metrics.mask import rates_from_counts


def test_mean_interval_is_scipys_percentile_bootstrap_of_the_sorted_values():
    values = [0.31, 0.05, 0.9, 0.42, 0.17, 0.66, 0.2]
    mean, lo, hi = mean_interval(values)
    ref = stats.bootstrap(
        (np.sort(values),), np.mean, n_resamples=N_RESAMPLES, method="percentile",
        rng=np.random.default_rng(SEED),
    )  # fmt: skip
    assert mean == pytest.approx(np.mean(values), abs=1e-15)
    assert (lo, hi) == (ref.confidence_interval.low, ref.confidence_interval.high)


def test_mean_interval_agrees_with_a_brute_force_resample():
    rng = np.random.default_rng(12345)
    values = rng.beta(0.5, 2.0, size=12)  # skewed, in [0, 1]
    idx = np.random.default_rng(7).integers(0, len(values), size=(400_000, len(values)))
    means = values[idx].mean(axis=1)
    want_lo, want_hi = np.percentile(means, [2.5, 97.5])
    _, lo, hi = mean_interval(values)
    assert lo == pytest.approx(want_lo, abs=0.006) and hi == pytest.approx(want_hi, abs=0.006)


def test_three_values_give_their_min_and_max_by_hand():
    # A resample of 3 is all-min with probability 1/27 = 3.7 % > 2.5 %: the 2.5 % quantile
    # of the resampled means is the smallest value, the 97.5 % quantile the largest.
    assert mean_interval([0.1, 0.2, 0.3]) == pytest.approx((0.2, 0.1, 0.3), abs=1e-15)


def test_a_binomial_resample_by_hand():
    # [0, 0, 0, 0, 1]: a resample's mean is K/5 with K ~ Binomial(5, 0.2).
    # P(K = 0) = 0.328 > 2.5 %, so low = 0; P(K <= 2) = 0.942 < 97.5 % < P(K <= 3) = 0.993,
    # so high = 3/5.
    k = np.arange(6)
    cdf = stats.binom.cdf(k, 5, 0.2)
    assert cdf[0] > 0.025 and cdf[2] < 0.975 < cdf[3]
    assert mean_interval([0, 0, 0, 0, 1]) == pytest.approx((0.2, 0.0, 0.6), abs=1e-15)


def test_intervals_stay_inside_the_range_where_student_t_does_not():
    values = [0.0, 0.0, 0.0, 0.9]  # off-road fractions of four seeds
    half = stats.t.ppf(0.975, 3) * np.std(values, ddof=1) / 2
    assert np.mean(values) - half < 0.0  # the old interval went below 0
    mean, lo, hi = mean_interval(values)
    assert 0.0 <= lo <= mean <= hi <= 1.0
    gen = np.random.default_rng(3)
    for n in range(2, 12):
        v = np.clip(gen.normal(gen.uniform(-0.5, 1.5), 0.7, size=n), 0.0, 1.0)  # many exact 0s and 1s
        mean, lo, hi = mean_interval(v)
        assert v.min() <= lo <= mean + 1e-12 and mean - 1e-12 <= hi <= v.max()


def test_degenerate_samples_are_said_plainly():
    assert all(math.isnan(x) for x in mean_interval([]))
    assert all(math.isnan(x) for x in mean_interval([None, math.nan, math.inf]))
    mean, lo, hi = mean_interval([0.7, math.nan, None])
    assert mean == 0.7 and math.isnan(lo) and math.isnan(hi)  # one episode: no interval
    assert mean_interval([0.25] * 4) == (0.25, 0.25, 0.25)  # no spread among the seeds


def test_interval_does_not_depend_on_the_order_of_the_episodes():
    values = [0.3, 0.1, 0.8, 0.55, 0.2, 0.05]
    shuffled = values[:]
    random.Random(1).shuffle(shuffled)
    assert shuffled != values and mean_interval(shuffled)[1:] == mean_interval(values)[1:]


@pytest.mark.parametrize(
    "k, n, want_lo, want_hi",
    [
        (0, 10, 0.0, 1 - 0.025 ** (1 / 10)),  # closed form: (alpha/2)^(1/n) at the ends
        (10, 10, 0.025 ** (1 / 10), 1.0),
        (0, 1, 0.0, 0.975),
        (3, 10, 0.0667, 0.6525),  # printed Clopper-Pearson tables
    ],
)
def test_clopper_pearson_by_hand(k, n, want_lo, want_hi):
    rate, lo, hi = proportion_interval([True] * k + [False] * (n - k))
    assert rate == k / n
    assert lo == pytest.approx(want_lo, abs=1e-4) and hi == pytest.approx(want_hi, abs=1e-4)
    # and the beta-quantile form of the same interval
    if 0 < k < n:
        assert lo == pytest.approx(stats.beta.ppf(0.025, k, n - k + 1), rel=1e-9)
        assert hi == pytest.approx(stats.beta.ppf(0.975, k + 1, n - k), rel=1e-9)


def test_bad_inputs_name_the_parameter():
    with pytest.raises(SimroadError, match="flags"):
        proportion_interval([0, 1, 0.5])
    with pytest.raises(SimroadError, match="confidence"):
        mean_interval([0.1, 0.2], confidence=1.0)
    with pytest.raises(SimroadError, match="n_resamples"):
        mean_interval([0.1, 0.2], n_resamples=0)
    assert all(math.isnan(x) for x in proportion_interval([None, math.nan]))


def _rec(scenario, seed, filters="none", driver="detector", *, score, noise="rain", severity=0.7, **kw):
    r = dict(scenario=scenario, seed=seed, filters=filters, driver=driver, noise=noise, severity=severity)
    r.update(detector="paper" if driver == "detector" else "", error=None)
    r.update(driving_score=score, offroad_fraction=kw.pop("offroad", 0.0), fnr=kw.pop("fnr", 0.1), fpr=0.01)
    r.update(kw)
    return r


def _hand_sweep():
    """Two scenarios, seeds 0-2; `all` changes the driving score by a known amount."""
    none = {("a", 0): 0.5, ("a", 1): 0.6, ("a", 2): 0.7, ("b", 0): 0.2, ("b", 1): 0.3, ("b", 2): 0.4}
    delta = {("a", 0): 0.1, ("a", 1): 0.2, ("a", 2): 0.3, ("b", 0): -0.1, ("b", 1): 0.0, ("b", 2): 0.4}
    recs = [_rec(s, k, score=v, offroad=0.1) for (s, k), v in none.items()]
    recs += [_rec(s, k, ALL_FILTERS, score=none[s, k] + d, offroad=0.0) for (s, k), d in delta.items()]
    recs += [_rec(s, k, driver="oracle", score=1.0, fnr=0.0) for (s, k) in none]
    # not paired: a seed without a `none` episode, a failed one, and another weather
    recs.append(_rec("a", 9, ALL_FILTERS, score=0.0))
    recs.append(_rec("b", 5, score=math.nan, error="RuntimeError"))
    recs.append(_rec("b", 5, ALL_FILTERS, score=0.9))
    recs += [_rec("a", k, f, noise="snow", score=0.1 * k) for k in range(3) for f in ("none", ALL_FILTERS)]
    return recs, delta, none


def test_pairs_are_matched_by_world_and_seed():
    recs, delta, none = _hand_sweep()
    rows = paired_differences(recs)
    key = {(r["noise"], r["scenario"], r["setting"]): r for r in rows}
    pooled = key["rain", "all", ALL_FILTERS]
    assert pooled["pairs"] == 6 and pooled["baseline"] == "none" and pooled["detector"] == "paper"
    assert pooled["driving_score_diff"] == pytest.approx(np.mean(list(delta.values())))
    off = (pooled[f"offroad_fraction_diff{s}"] for s in ("", "_lo", "_hi"))
    assert tuple(off) == pytest.approx((-0.1, -0.1, -0.1))  # every pair -0.1: no spread
    want = mean_interval(list(delta.values()))
    assert (pooled["driving_score_diff_lo"], pooled["driving_score_diff_hi"]) == pytest.approx(want[1:], abs=1e-12)
    a, b = key["rain", "a", ALL_FILTERS], key["rain", "b", ALL_FILTERS]
    assert a["pairs"] == b["pairs"] == 3
    assert a["driving_score_diff"] == pytest.approx(0.2)
    assert (a["driving_score_diff_lo"], a["driving_score_diff_hi"]) == pytest.approx((0.1, 0.3))  # 3 pairs: min, max
    assert b["driving_score_diff"] == pytest.approx(0.1)
    oracle = key["rain", "all", "oracle"]
    assert oracle["pairs"] == 6 and oracle["driving_score_diff"] == pytest.approx(1 - np.mean(list(none.values())))
    assert oracle["fnr_diff"] == pytest.approx(-0.1)
    snow = key["snow", "all", ALL_FILTERS]  # its own cell, not mixed with rain: 0 - 0 in every pair
    assert snow["pairs"] == 3 and snow["driving_score_diff"] == 0.0
    # rows: per weather, each setting pooled then per scenario (snow has no oracle)
    assert [(r["noise"], r["setting"], r["scenario"]) for r in rows] == [
        ("rain", ALL_FILTERS, "all"), ("rain", ALL_FILTERS, "a"), ("rain", ALL_FILTERS, "b"),
        ("rain", "oracle", "all"), ("rain", "oracle", "a"), ("rain", "oracle", "b"),
        ("snow", ALL_FILTERS, "all"), ("snow", ALL_FILTERS, "a"),
    ]  # fmt: skip


def test_pairing_does_not_depend_on_the_order_of_the_records():
    recs, _, _ = _hand_sweep()
    for seed in (1, 2):
        shuffled = recs[:]
        random.Random(seed).shuffle(shuffled)
        assert shuffled != recs and paired_differences(shuffled) == paired_differences(recs)


def test_one_pair_has_no_interval():
    rows = paired_differences([_rec("a", 0, score=0.5), _rec("a", 0, ALL_FILTERS, score=0.8)])
    assert rows[0]["pairs"] == 1 and rows[0]["driving_score_diff"] == pytest.approx(0.3)
    assert math.isnan(rows[0]["driving_score_diff_lo"]) and math.isnan(rows[0]["driving_score_diff_hi"])


# -- pooled FNR + FPR, paired, resampling episodes ---------------------------------------


def _counts(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-episode (tp, fp, fn, tn) of a setting and its baseline: episodes of unequal
    size and difficulty; the setting misses 30 % fewer road pixels, calls a few more road."""
    gen = np.random.default_rng(seed)
    road, other = gen.integers(200, 2000, n), gen.integers(200, 2000, n)
    miss, false_road = gen.uniform(0.05, 0.6, n), gen.uniform(0.01, 0.1, n)
    fn_b, fp_b = gen.binomial(road, miss), gen.binomial(other, false_road)
    fn_a, fp_a = gen.binomial(road, 0.7 * miss), gen.binomial(other, 1.2 * false_road)
    return (np.stack([road - fn_a, fp_a, fn_a, other - fp_a], 1), np.stack([road - fn_b, fp_b, fn_b, other - fp_b], 1))


def test_fnr_plus_fpr_is_the_metrics_own():
    for row in _counts(1, 5)[0]:
        want = rates_from_counts(*map(int, row))
        assert fnr_plus_fpr(row) == want["fnr"] + want["fpr"]
    assert math.isnan(fnr_plus_fpr([0, 3, 0, 7]))  # no road pixel: FNR undefined


def test_pooled_difference_agrees_with_a_brute_force_resample_of_episodes():
    a, b = _counts(2, 9)
    diff, lo, hi = paired_pooled_difference(a, b)
    assert diff == fnr_plus_fpr(a.sum(0)) - fnr_plus_fpr(b.sum(0))  # ratio of sums
    idx = np.random.default_rng(7).integers(0, len(a), size=(200_000, len(a)))  # the same episodes for both
    diffs = fnr_plus_fpr(a[idx].sum(1)) - fnr_plus_fpr(b[idx].sum(1))
    want_lo, want_hi = np.percentile(diffs, [2.5, 97.5])
    assert lo == pytest.approx(want_lo, abs=0.002) and hi == pytest.approx(want_hi, abs=0.002)
    assert lo < diff < hi
    # resampling a and b independently would ignore the pairing and give a wider interval
    other = np.random.default_rng(8).integers(0, len(a), size=idx.shape)
    unpaired = np.percentile(fnr_plus_fpr(a[idx].sum(1)) - fnr_plus_fpr(b[other].sum(1)), [2.5, 97.5])
    assert unpaired[1] - unpaired[0] > 1.5 * (hi - lo)


def test_pooled_difference_does_not_depend_on_the_order_of_the_episodes():
    a, b = _counts(3, 7)
    order = np.random.default_rng(4).permutation(7)
    assert paired_pooled_difference(a[order], b[order]) == paired_pooled_difference(a, b)


def test_pooled_difference_degenerate_cases():
    a, b = _counts(5, 3)
    assert all(math.isnan(x) for x in paired_pooled_difference([], []))
    diff, lo, hi = paired_pooled_difference(a[:1], b[:1])  # one episode: no interval
    assert diff == pytest.approx(fnr_plus_fpr(a[0]) - fnr_plus_fpr(b[0]), abs=1e-15)
    assert math.isnan(lo) and math.isnan(hi)
    assert paired_pooled_difference(a, a) == (0.0, 0.0, 0.0)
    no_road = [[0, 1, 0, 9], [0, 2, 0, 8]]  # FNR undefined however the episodes are drawn
    assert all(math.isnan(x) for x in paired_pooled_difference(no_road, no_road)[1:])


@pytest.mark.parametrize(
    ("setting", "baseline", "match"),
    [
        ([[1, 2, 3]], [[1, 2, 3, 4]], r"setting: .*shape \(episodes, 4\)"),
        ([[1, 2, 3, 4]], [[1, 2, 3, -4]], "baseline: .*non-negative integer"),
        ([[1, 2, 3.5, 4]], [[1, 2, 3, 4]], "setting: .*integer pixel counts, got 3.5"),
        ([[1, 2, 3, 4]], [[1, 2, 3, 4]] * 2, "same episodes"),
        ([["a", 2, 3, 4]], [[1, 2, 3, 4]], "setting"),
    ],
)
def test_pooled_difference_bad_counts_name_the_parameter(setting, baseline, match):
    with pytest.raises(SimroadError, match=match):
        paired_pooled_difference(setting, baseline)
    with pytest.raises(SimroadError, match="confidence"):
        paired_pooled_difference([[1, 2, 3, 4]], [[1, 2, 3, 4]], confidence=0.0)
