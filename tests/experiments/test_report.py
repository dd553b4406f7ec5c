"""Sweep reports: every file's content checked against the records, intervals in range, paired rows."""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import cv2
import pytest

from simroad import SimroadError
from simroad.experiments.report import METRICS, SKY_COLUMN, build_report, summarise
from simroad.experiments.results import ResultStore
from simroad.experiments.stats import mean_interval, proportion_interval

sys.path.insert(0, str(Path(__file__).parent))
from stub_cell import fake_record as _record

FNR = {0: 0.1, 1: 0.2, 2: 0.3}


@pytest.fixture
def sweep(tmp_path):
    """A small sweep on disk: rain 0.7 and clear, two filter sets and the oracle,
    three seeds, one failed episode."""
    store = ResultStore(tmp_path)
    records = []
    for seed, fnr in FNR.items():
        # no filters: sky costs 0.1, 0.2, 0.3 points of whole-image FPR; all filters: 4 points
        records.append(_record(seed=seed, fnr=fnr, fpr=fnr / 10, fpr_image=fnr / 10 + 0.001 * (seed + 1),
                               offroad_fraction=0.1 * seed, driving_score=1 - fnr, route_completion=0.1,
                               mean_speed_m_s=1.0 + seed, slide_steps=seed))  # fmt: skip
        records.append(_record(seed=seed, filters="shadow+rain_snow+light", fnr=fnr / 2, fpr=0.01, fpr_image=0.05,
                               driving_score=0.9, route_completion=0.5, mean_speed_m_s=5.0, slide_steps=2))  # fmt: skip
        records.append(_record(seed=seed, driver="oracle", fnr=0.0, driving_score=1.0, collided=seed == 2,
                               route_completion=0.9, mean_speed_m_s=8.0))  # fmt: skip
        records.append(_record(seed=seed, noise="clear", severity=0.0, fnr=0.05, driving_score=1.0))
    failed = _record(seed=3, fnr=math.nan, driving_score=math.nan, steps=0, error="RuntimeError: boom")
    for r in [*records, failed]:
        store.append(r)
    return tmp_path, records


def _row(rows, **kw):
    return next(r for r in rows if all(r[k] == v for k, v in kw.items()))


def test_summary_rows_hold_each_mean_with_its_interval(sweep):
    _, records = sweep
    rows = summarise([*records, _record(seed=3, fnr=math.nan, error="RuntimeError: boom")])
    row = _row(rows, noise="rain", filters="none", driver="detector")
    assert (row["episodes"], row["failed"]) == (4, 1)
    # three seeds: the percentile bootstrap of 0.1, 0.2, 0.3 is [0.1, 0.3] (tests/experiments/test_stats.py)
    assert (row["fnr"], row["fnr_lo"], row["fnr_hi"]) == pytest.approx((0.2, 0.1, 0.3))
    assert (row["offroad_fraction"], row["offroad_fraction_lo"]) == pytest.approx((0.1, 0.0))
    assert (row[SKY_COLUMN], row[f"{SKY_COLUMN}_lo"], row[f"{SKY_COLUMN}_hi"]) == pytest.approx((0.002, 0.001, 0.003))
    assert row["fpr_image"] == pytest.approx(0.022)
    oracle = _row(rows, driver="oracle")
    cp = proportion_interval([False, False, True])
    assert (oracle["collision_rate"], oracle["collision_rate_lo"], oracle["collision_rate_hi"]) == cp
    assert cp[0] == pytest.approx(1 / 3) and 0.0 < cp[1] < 1 / 3 < cp[2] < 1.0
    assert oracle["fnr_image"] == oracle["fpr_image"] == 0.0
    for col in METRICS:
        assert {col, f"{col}_lo", f"{col}_hi"} <= set(row)
    bounded = ("fnr", "fpr", "fnr_image", "fpr_image", "iou", "offroad_fraction", "collision_rate", "driving_score")
    for r in rows:
        for col in bounded:
            lo, hi = r[f"{col}_lo"], r[f"{col}_hi"]
            assert 0.0 <= lo <= r[col] <= hi <= 1.0, (r, col)
        want = mean_interval(x["driving_score"] for x in records if all(
            x[k] == r[k] for k in ("scenario", "noise", "severity", "filters", "driver", "detector")))  # fmt: skip
        assert (r["driving_score"], r["driving_score_lo"], r["driving_score_hi"]) == want


def test_build_report_writes_every_file_with_the_summary_values(sweep):
    d, _ = sweep
    paths = build_report(d)
    assert sorted(paths) == [
        "error_rates.png", "paired.csv", "paired.json", "paired.png", "safety.png",
        "summary.csv", "summary.json", "summary.md",
    ]  # fmt: skip
    assert all(p.parent == d and p.is_file() for p in paths.values())
    expected = summarise([json.loads(line) for line in (d / "results.jsonl").read_text().splitlines()])

    with open(paths["summary.csv"], newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(expected) == 4  # rain x {none, all, oracle} + clear x none
    for got, want in zip(rows, expected):
        assert got["filters"] == want["filters"] and int(got["episodes"]) == want["episodes"]
        for col in ("fnr", "fnr_lo", "fnr_hi", "fpr_image", SKY_COLUMN, "driving_score_hi", "collision_rate_lo"):
            assert float(got[col]) == pytest.approx(want[col], nan_ok=True)

    as_json = json.loads(paths["summary.json"].read_text())
    assert [r["filters"] for r in as_json] == [r["filters"] for r in expected]
    rain_none = _row(as_json, noise="rain", filters="none", driver="detector")
    assert rain_none["fnr"] == pytest.approx(0.2) and rain_none["failed"] == 1

    md = paths["summary.md"].read_text()
    assert md.startswith("# Ablation summary") and "## At a glance" in md and "## Per cell" in md
    # per-cell FNR in percent with its interval; whole-image minus ground FPR; collision rate
    assert "| 20.00 [10.00, 30.00] |" in md and "| 0.20 [0.10, 0.30] |" in md
    assert f"| {100 * proportion_interval([0, 0, 1])[0]:.1f} [" in md
    # at a glance: FNR / FPR of no filters and all filters, the worst sky cost (4 points),
    # and the paired all - none driving score: pairs 0.9 - {0.9, 0.8, 0.7}
    assert "| rain | 0.7 | 20.0 / 2.0 | 10.0 / 1.0 |" in md
    assert "| 4.00 | 0.100 [0.000, 0.200] (3 pairs) |" in md
    # why a score moved: route completion %, mean speed and slide steps (none / all / oracle)
    assert "| 10 / 50 / 90 | 2.0 / 5.0 / 8.0 | 1.0 / 2.0 / 0.0 |" in md
    # the paired section: all filters and the oracle against none
    section = md.split("## Filters vs none, paired")[1].split("## Per cell")[0]
    assert "| rain | 0.7 | all filters | 3 | 0.100 [0.000, 0.200] | -10.00 [-20.00, 0.00] |" in section
    assert "| rain | 0.7 | oracle | 3 | 0.200 [0.100, 0.300] |" in section

    with open(paths["paired.csv"], newline="") as fh:
        paired = list(csv.DictReader(fh))
    assert [(p["scenario"], p["setting"]) for p in paired] == [
        ("all", "shadow+rain_snow+light"), ("racetrack", "shadow+rain_snow+light"),
        ("all", "oracle"), ("racetrack", "oracle"),
    ]  # fmt: skip
    assert json.loads(paths["paired.json"].read_text())[0]["pairs"] == 3

    for name, size in (("error_rates.png", (1350, 342)), ("safety.png", (288, 495)), ("paired.png", (540, 324))):
        assert paths[name].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = cv2.imread(str(paths[name]))
        assert img is not None and (img.shape[1], img.shape[0]) == size  # figsize x dpi 90
        assert img.std() > 10  # something is drawn


def test_the_same_results_give_the_same_report_byte_for_byte(sweep, tmp_path_factory):
    d, _ = sweep
    other = tmp_path_factory.mktemp("again")
    (other / "results.jsonl").write_bytes((d / "results.jsonl").read_bytes())
    first, second = build_report(d), build_report(other)
    for name, path in first.items():
        assert path.read_bytes() == second[name].read_bytes(), name


def test_report_of_a_directory_without_results_says_what_to_run(tmp_path):
    with pytest.raises(SimroadError, match="simroad ablate"):
        build_report(tmp_path)


def test_report_refuses_a_results_path_that_is_a_directory(tmp_path, capsys):
    (tmp_path / "results.jsonl").mkdir()
    with pytest.raises(SimroadError, match=r"^dir: .*results\.jsonl' is not a regular file"):
        build_report(tmp_path)
    from simroad.cli.main import main

    assert main(["report", str(tmp_path)]) == 2  # was an IsADirectoryError traceback
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize("directory", [5, None, ""])
def test_report_refuses_a_directory_that_is_not_a_path(directory):
    with pytest.raises(SimroadError, match=r"^dir: expected a directory path"):
        build_report(directory)


def test_rows_written_before_the_start_speed_are_summarised_without_it():
    old = [_record(seed=s, start_speed_m_s=None) for s in range(2)]
    for r in old:
        r.pop("start_speed_m_s")
    new = [_record(seed=s, start_speed_m_s=v) for s, v in ((2, 10.0), (3, 12.0))]
    (row,) = summarise(old + new)
    assert row["episodes"] == 4 and row["start_speed_m_s"] == pytest.approx(11.0)  # the two that hold it
    (row,) = summarise(old)
    assert math.isnan(row["start_speed_m_s"])  # none holds it: no mean, not 0
