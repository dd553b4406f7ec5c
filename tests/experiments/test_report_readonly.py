"""One definition of a valid results row; the report only reads, and names every line it cannot use."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from simroad import SimroadError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.episode import RECORD_KEYS
from simroad.experiments.grid import AblationGrid
from simroad.experiments.report import build_report
from simroad.experiments.results import ROW_TYPES, ResultStore, check_row, read_results

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from stub_cell import fake_record as _record  # noqa: E402
from stub_cell import stub_cell  # noqa: E402


def _line(**kw) -> str:
    return json.dumps(_record(**kw))


def test_every_record_key_has_a_type_and_real_records_are_valid():
    assert set(RECORD_KEYS) | {"error"} == set(ROW_TYPES)
    assert check_row(_record()) is None
    assert check_row(_record(min_ttc_s=1.5, collided=True, error="RuntimeError: boom")) is None
    # a failed episode: every metric NaN (run_cell), identity kept
    failed = dict.fromkeys(RECORD_KEYS, math.nan)
    failed.update(
        scenario="racetrack",
        noise="clear",
        severity=0.0,
        filters="none",
        driver="oracle",
        seed=1,
        steps=0,
        step_budget=5,
    )
    failed.update(detector="", detector_version="", detector_spec="", camera_profile={"tone_gamma": 1.6},
                  detector_options={}, env_options={"width": 160})  # fmt: skip
    assert check_row(json.loads(json.dumps(failed))) is None
    # the stub's rows (all floats) and a row without the optional error key
    stub = {k: v for k, v in _record(collided=0.0, offroad_steps=0.0).items() if k != "error"}
    assert check_row(stub) is None


@pytest.mark.parametrize(
    "change, words",
    [({"severity": "high"}, "severity is 'high' (str)"), ({"severity": 1.5}, "severity is 1.5"),
     ({"scenario": 5}, "scenario is 5 (int)"), ({"scenario": ""}, "scenario is ''"), ({"noise": None}, "noise is None"),
     ({"filters": ["rain"]}, "filters is ['rain']"), ({"driver": 1}, "driver is 1"), ({"seed": "3"}, "seed is '3'"),
     ({"seed": 1.5}, "seed is 1.5"), ({"seed": -1}, "seed is -1"), ({"seed": True}, "seed is True"),
     ({"steps": None}, "steps is None"), ({"fnr": "0.1"}, "fnr is '0.1'"), ({"fpr": None}, "fpr is None"),
     ({"fnr": True}, "fnr is True"), ({"collided": "no"}, "collided is 'no'"), ({"min_ttc_s": "inf"}, "min_ttc_s is"),
     ({"driving_score": [1]}, "driving_score is [1]"), ({"error": 3}, "error is 3")],
)  # fmt: skip
def test_a_wrong_type_is_named_with_its_key(change, words):
    reason = check_row(_record(**change))
    assert reason is not None and words in reason


def test_missing_keys_and_non_objects_are_named():
    assert "missing keys severity, filters" in (check_row({"scenario": "racetrack", "noise": "clear"}) or "")
    only = {k: v for k, v in _record().items() if k != "wall_s"}
    assert check_row(only) == "missing key wall_s"
    assert check_row([1, 2]) == "not a JSON object but list" and check_row(5) == "not a JSON object but int"


def _damaged_file(path: Path) -> dict[int, str]:
    """Valid rows with every kind of bad line among them; returns line number -> expected words."""
    lines = [
        _line(seed=0, fnr=0.1),  # 1
        _line(seed=1, fnr=0.2),  # 2
        "this is not json",  # 3
        _line(seed=2, severity="high"),  # 4
        _line(seed=3, scenario=5),  # 5
        json.dumps({"scenario": "racetrack"}),  # 6
        "",  # 7
        "[1, 2, 3]",  # 8
        _line(seed=1, fnr=0.9),  # 9: a second row for seed 1
        _line(seed=4, fnr=0.3),  # 10
        _line(seed=5, fnr=0.4)[:40],  # 11: torn, no newline
    ]
    path.write_bytes(("\n".join(lines)).encode())
    return {3: "not JSON", 4: "severity is 'high'", 5: "scenario is 5", 6: "missing keys", 7: "empty line",
            8: "not a JSON object", 9: "duplicate of line 2", 11: "torn"}  # fmt: skip


def test_read_results_names_each_bad_line_and_keeps_only_valid_rows(tmp_path):
    expected = _damaged_file(tmp_path / "results.jsonl")
    rows, bad = read_results(tmp_path / "results.jsonl")
    assert [r["seed"] for r in rows] == [0, 1, 4]
    assert [r["fnr"] for r in rows] == [0.1, 0.2, 0.3]  # the first row of seed 1 wins
    assert {b.number: b.reason for b in bad}.keys() == expected.keys()
    for b in bad:
        assert expected[b.number] in b.reason and str(b).startswith(f"line {b.number}: ")
    assert [b.number for b in bad if b.torn] == [11] and [b.number for b in bad if b.duplicate] == [9]


@pytest.mark.slow
def test_simroad_report_leaves_results_byte_identical_and_names_every_bad_line(tmp_path):
    expected = _damaged_file(tmp_path / "results.jsonl")
    before = (tmp_path / "results.jsonl").read_bytes()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "simroad", "report", str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "results.jsonl").read_bytes() == before
    assert not (tmp_path / "results.rejected.jsonl").exists() and "Traceback" not in proc.stderr
    md = (tmp_path / "summary.md").read_text()
    for number, words in expected.items():
        said = [line for line in proc.stderr.splitlines() if f"line {number}: " in line]
        assert len(said) == 1 and words in said[0], (number, proc.stderr)
        assert f"- line {number}: " in md
    # only the three valid rows enter the summary: mean FNR (0.1 + 0.2 + 0.3) / 3
    (row,) = json.loads((tmp_path / "summary.json").read_text())
    assert row["episodes"] == 3 and row["fnr"] == pytest.approx(0.2)


def test_report_of_only_bad_lines_is_an_error_that_changes_nothing(tmp_path):
    path = tmp_path / "results.jsonl"
    path.write_text(_line(severity="high") + "\n")
    said: list[str] = []
    with pytest.raises(SimroadError, match="no finished episode"):
        build_report(tmp_path, log=said.append)
    assert said == [f"{path}: line 1: severity is 'high' (str), expected a number in [0, 1]; not used"]
    assert path.read_text() == _line(severity="high") + "\n"


GRID = AblationGrid(scenarios=("racetrack",), noises=("clear",), filters=("none",), seeds=4, steps=5)


def test_runner_moves_a_torn_last_line_aside_and_says_so(tmp_path):
    run_ablation(GRID, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    path = tmp_path / "results.jsonl"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:5]) + "\n" + lines[5][:30])  # 5 rows, then a torn sixth
    said: list[str] = []
    done = ResultStore(tmp_path, log=said.append).open(GRID)
    assert len(done) == 5 and path.read_text() == "\n".join(lines[:5]) + "\n"
    (moved,) = [json.loads(x) for x in (tmp_path / "results.rejected.jsonl").read_text().splitlines()]
    assert moved["line"] == 6 and moved["text"] == lines[5][:30] and moved["reason"].startswith("torn")
    assert len(said) == 1 and "line 6: torn" in said[0] and "results.rejected.jsonl" in said[0]
    records = run_ablation(GRID, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    assert len(records) == 8 and read_results(path)[1] == []


def test_runner_refuses_a_bad_line_it_did_not_write_and_changes_nothing(tmp_path):
    run_ablation(GRID, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    path = tmp_path / "results.jsonl"
    lines = path.read_text().splitlines()
    lines[2] = lines[2].replace('"seed": 1', '"seed": "one"')
    path.write_text("\n".join(lines) + "\n")
    before = path.read_bytes()
    with pytest.raises(SimroadError, match=r"line 3: seed is 'one' \(str\)") as err:
        run_ablation(GRID, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    assert "--fresh" in str(err.value) and path.read_bytes() == before
