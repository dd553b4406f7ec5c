"""Sweep reports: Student-t intervals worked by hand, and every file's content checked."""

from __future__ import annotations

import csv
import json
import math

import cv2
import numpy as np
import pytest
from scipy import stats

from simroad import SimroadError
from simroad.experiments.ablate import ResultStore
from simroad.experiments.episode import RECORD_KEYS
from simroad.experiments.report import METRICS, _mean_ci, build_report, summarise

# t_{0.975} quantiles from a printed Student-t table (two-sided 95 %).
T_TABLE = {1: 12.706, 2: 4.303, 4: 2.776}


def test_mean_ci_by_hand_five_values():
    # 1..5: mean 3, sample sd sqrt(2.5), n 5, 4 degrees of freedom
    mean, half = _mean_ci([1.0, 2.0, 3.0, 4.0, 5.0])
    assert mean == 3.0
    assert half == pytest.approx(T_TABLE[4] * math.sqrt(2.5) / math.sqrt(5), rel=2e-4)  # 1.9632...
    assert half == pytest.approx(stats.t.ppf(0.975, 4) * np.std([1, 2, 3, 4, 5], ddof=1) / math.sqrt(5), rel=1e-12)


def test_mean_ci_by_hand_two_values():
    # 0 and 1: mean 0.5, sd 1/sqrt(2), n 2 -> half-width 12.706 * 0.7071 / 1.4142 = 6.353
    mean, half = _mean_ci([0.0, 1.0])
    assert mean == 0.5 and half == pytest.approx(T_TABLE[1] / 2, rel=1e-4)


def test_mean_ci_drops_missing_values_and_handles_tiny_samples():
    mean, half = _mean_ci([0.1, None, math.nan, 0.2, math.inf, 0.3])
    assert mean == pytest.approx(0.2) and half == pytest.approx(T_TABLE[2] * 0.1 / math.sqrt(3), rel=1e-4)
    mean, half = _mean_ci([0.7])
    assert mean == 0.7 and math.isnan(half)  # one seed: no interval
    assert all(math.isnan(v) for v in _mean_ci([]))


def _record(**kw):
    r = dict.fromkeys(RECORD_KEYS, 0.0)
    r.update(scenario="racetrack", noise="rain", severity=0.7, filters="none", driver="detector", seed=0, steps=5)
    r.update(detector="paper", detector_version="", detector_spec="paper")
    r.update(collided=False, min_ttc_s=None, error=None)
    r.update(kw)
    return r


FNR = {0: 0.1, 1: 0.2, 2: 0.3}


@pytest.fixture
def sweep(tmp_path):
    """A small sweep on disk: rain 0.7 and clear, two filter sets and the oracle,
    three seeds, one failed episode."""
    store = ResultStore(tmp_path)
    records = []
    for seed, fnr in FNR.items():
        records.append(_record(seed=seed, fnr=fnr, fpr=fnr / 10, offroad_fraction=0.1 * seed, driving_score=1 - fnr))
        records.append(_record(seed=seed, filters="shadow+rain_snow+light", fnr=fnr / 2, fpr=0.01, driving_score=0.9))
        records.append(_record(seed=seed, driver="oracle", fnr=0.0, driving_score=1.0, collided=seed == 2))
        records.append(_record(seed=seed, noise="clear", severity=0.0, fnr=0.05, driving_score=1.0))
    failed = _record(seed=3, fnr=math.nan, driving_score=math.nan, steps=0, error="RuntimeError: boom")
    for r in [*records, failed]:
        store.append(r)
    return tmp_path, records


def test_summary_rows_equal_the_hand_computed_means_and_intervals(sweep):
    _, records = sweep
    rows = summarise([*records, _record(seed=3, fnr=math.nan, error="RuntimeError: boom")])
    row = next(r for r in rows if r["noise"] == "rain" and r["filters"] == "none" and r["driver"] == "detector")
    assert (row["episodes"], row["failed"]) == (4, 1)
    assert row["fnr"] == pytest.approx(0.2)
    assert row["fnr_ci95"] == pytest.approx(T_TABLE[2] * 0.1 / math.sqrt(3), rel=1e-4)  # 0.2484
    assert row["offroad_fraction"] == pytest.approx(0.1)
    oracle = next(r for r in rows if r["driver"] == "oracle")
    assert oracle["collision_rate"] == pytest.approx(1 / 3)  # `collided` averaged
    assert set(METRICS) | {f"{m}_ci95" for m in METRICS} <= set(row)


def test_build_report_writes_every_file_with_the_summary_values(sweep):
    d, _ = sweep
    paths = build_report(d)
    assert sorted(paths) == ["error_rates.png", "safety.png", "summary.csv", "summary.json", "summary.md"]
    assert all(p.parent == d and p.is_file() for p in paths.values())
    expected = summarise([json.loads(line) for line in (d / "results.jsonl").read_text().splitlines()])

    with open(paths["summary.csv"], newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(expected) == 4  # rain x {none, all, oracle} + clear x none
    for got, want in zip(rows, expected):
        assert got["filters"] == want["filters"] and int(got["episodes"]) == want["episodes"]
        for col in ("fnr", "fnr_ci95", "driving_score", "collision_rate"):
            assert float(got[col]) == pytest.approx(want[col], nan_ok=True)

    as_json = json.loads(paths["summary.json"].read_text())
    assert [r["filters"] for r in as_json] == [r["filters"] for r in expected]
    rain_none = next(
        r for r in as_json if r["noise"] == "rain" and r["filters"] == "none" and r["driver"] == "detector"
    )
    assert rain_none["fnr"] == pytest.approx(0.2) and rain_none["failed"] == 1

    md = paths["summary.md"].read_text()
    assert md.startswith("# Ablation summary") and "## At a glance" in md and "## Per cell" in md
    # per-cell FNR in percent with its half-width, and the at-a-glance FNR / FPR of no filters
    assert "| 20.00 ± 24.84 |" in md
    assert "| rain | 0.7 | 20.0 / 2.0 | 10.0 / 1.0 |" in md

    for name, size in (("error_rates.png", (990, 342)), ("safety.png", (288, 495))):
        assert paths[name].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = cv2.imread(str(paths[name]))
        assert img is not None and (img.shape[1], img.shape[0]) == size  # figsize x dpi 90
        assert img.std() > 10  # something is drawn


def test_report_of_a_directory_without_results_says_what_to_run(tmp_path):
    with pytest.raises(SimroadError, match="simroad ablate"):
        build_report(tmp_path)
