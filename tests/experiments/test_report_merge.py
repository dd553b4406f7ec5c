"""A report over several sweeps, and cells told apart by their step budget."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from simroad import SimroadError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid, cell_key
from simroad.experiments.report import build_report
from simroad.experiments.results import read_results

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from stub_cell import stub_cell  # noqa: E402

EXAMPLE = f"{HERE.parents[1] / 'examples' / 'pixel_detector.py'}:LabPixelDetector"
PAPER = AblationGrid(scenarios=("racetrack",), noises=("clear", "rain"), filters=("none",), seeds=3, steps=5)


def _rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _sweep(tmp_path: Path, name: str, grid: AblationGrid) -> Path:
    run_ablation(grid, tmp_path / name, workers=1, progress=False, cell_fn=stub_cell)
    return tmp_path / name


def test_a_report_over_two_sweeps_keeps_every_row_and_pairs_their_detectors(tmp_path):
    """A sweep of the paper's detector and one of the user's on the same worlds: the
    report over both holds every row of each and the head-to-head of the two."""
    a = _sweep(tmp_path, "paper", PAPER)
    b = _sweep(tmp_path, "mine", replace(PAPER, detectors=(EXAMPLE,), oracle=False))
    said: list[str] = []
    paths = build_report(a, b, out=tmp_path / "both", log=said.append)
    merged = _rows(paths["results.jsonl"])
    expected = {cell_key(r) for r in _rows(a / "results.jsonl") + _rows(b / "results.jsonl")}
    assert {cell_key(r) for r in merged} == expected and len(merged) == len(expected) == 12 + 6
    assert said == []  # nothing left out
    sources = json.loads(paths["sources.json"].read_text())
    assert [s["rows_used"] for s in sources["sources"]] == [12, 6] and sources["rows"] == 18
    paired = json.loads(paths["paired.json"].read_text())
    h2h = [p for p in paired if p["comparison"] == "detectors" and p["scenario"] == "all"]
    label = f"{EXAMPLE} − paper"  # the stub episode names a detector by its spec
    assert sorted((p["noise"], p["detector"]) for p in h2h) == [("clear", label), ("rain", label)]
    assert all(p["pairs"] == 3 for p in h2h)  # paired on the three shared worlds
    assert label in paths["summary.md"].read_text()
    # the merged folder is a report folder of its own: rebuilt byte for byte from its rows
    before = {n: paths[n].read_bytes() for n in ("summary.md", "summary.csv", "paired.json")}
    build_report(tmp_path / "both")
    assert {n: paths[n].read_bytes() for n in before} == before
    # the sources were only read
    assert len(_rows(a / "results.jsonl")) == 12 and len(_rows(b / "results.jsonl")) == 6


def test_a_cell_in_two_sweeps_is_kept_once_and_the_second_named(tmp_path):
    a = _sweep(tmp_path, "a", PAPER)
    b = _sweep(tmp_path, "b", replace(PAPER, seeds=4))  # seeds 0-2 again, and seed 3
    said: list[str] = []
    paths = build_report(a, b, out=tmp_path / "ab", log=said.append)
    assert len(_rows(paths["results.jsonl"])) == 16  # 12 of a + the 4 new cells of seed 3
    assert len(said) == 12 and all(str(b / "results.jsonl") in m and "duplicate of" in m for m in said)
    assert str(a / "results.jsonl") in said[0]  # names where the kept row is
    assert "duplicate of" in paths["summary.md"].read_text()


def test_rows_of_different_step_budgets_are_different_cells_reported_apart(tmp_path):
    """Two sweeps of the same cells for 5 and for 8 steps, their results.jsonl concatenated:
    no row is lost as a duplicate, and no pair or mean mixes the two budgets."""
    a = _sweep(tmp_path, "short", PAPER)
    b = _sweep(tmp_path, "long", replace(PAPER, steps=8))
    cat = tmp_path / "cat"
    cat.mkdir()
    (cat / "results.jsonl").write_text((a / "results.jsonl").read_text() + (b / "results.jsonl").read_text())
    rows, bad = read_results(cat / "results.jsonl")
    assert bad == [] and len(rows) == 24
    paths = build_report(cat)
    scenarios = {r["scenario"] for r in json.loads(paths["summary.json"].read_text())}
    assert scenarios == {"racetrack (5 steps)", "racetrack (8 steps)"}
    per_scenario = [p for p in json.loads(paths["paired.json"].read_text()) if p["scenario"] != "all"]
    assert per_scenario and all(p["pairs"] == 3 for p in per_scenario)  # never a 5-step row against an 8-step one


def test_rows_written_before_the_budget_take_the_grids_steps(tmp_path):
    """A sweep written before records held ``step_budget`` resumes without rerunning a cell."""
    out = _sweep(tmp_path, "old", PAPER)
    path = out / "results.jsonl"
    rows = _rows(path)
    path.write_text("".join(json.dumps({k: v for k, v in r.items() if k != "step_budget"}) + "\n" for r in rows))
    ran: list[str] = []

    def counting(spec):
        ran.append(cell_key(spec))
        return stub_cell(spec)

    records = run_ablation(PAPER, out, workers=1, progress=False, cell_fn=counting)
    assert ran == [] and len(records) == 12 and all(r["step_budget"] == 5 for r in records)


def test_a_merged_report_refuses_a_sweep_folder_or_no_out(tmp_path):
    a = _sweep(tmp_path, "a", PAPER)
    b = _sweep(tmp_path, "b", replace(PAPER, seeds=4))
    with pytest.raises(SimroadError, match="out: a report over 2 sweeps needs a folder of its own"):
        build_report(a, b)
    with pytest.raises(SimroadError, match="is one of the sweeps reported"):
        build_report(a, b, out=b)
    other = _sweep(tmp_path, "c", replace(PAPER, seeds=1))
    before = (other / "results.jsonl").read_bytes()
    with pytest.raises(SimroadError, match=r"holds a sweep's own results\.jsonl"):
        build_report(a, b, out=other)
    assert (other / "results.jsonl").read_bytes() == before


def test_simroad_report_takes_several_directories(tmp_path):
    a = _sweep(tmp_path, "a", PAPER)
    b = _sweep(tmp_path, "b", replace(PAPER, detectors=(EXAMPLE,), oracle=False))
    run = subprocess.run([sys.executable, "-m", "simroad", "report", str(a), str(b), "--out", str(tmp_path / "r")],
                         capture_output=True, text=True)  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert len(_rows(tmp_path / "r" / "results.jsonl")) == 18 and (tmp_path / "r" / "paired.png").stat().st_size
    refused = subprocess.run(
        [sys.executable, "-m", "simroad", "report", str(a), str(b)], capture_output=True, text=True
    )
    assert refused.returncode == 2 and "needs a folder of its own" in refused.stderr
