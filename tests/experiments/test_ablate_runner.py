"""The sweep runner with a stub episode: resumable, crash-safe, one row per cell."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from simroad import SimroadError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.episode import EpisodeSpec
from simroad.experiments.grid import AblationGrid, cell_key, load_grid_file
from simroad.experiments.results import ResultStore

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from stub_cell import FAILING_DRIVER, FAILING_SEED, stub_cell  # noqa: E402

EXAMPLE = f"{HERE.parents[1] / 'examples' / 'pixel_detector.py'}:LabPixelDetector"
GRID = AblationGrid(
    scenarios=("racetrack",),
    noises=("clear", "rain"),
    severities=(0.4, 0.8),
    filters=("none", "all"),
    seeds=10,
    steps=5,
)


def _rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_grid_cells_count_and_clear_runs_once():
    specs = GRID.specs()
    # clear: 1 severity; rain: 2 severities; x 10 seeds x (oracle + 2 filter sets)
    assert len(specs) == (1 + 2) * 10 * 3
    assert len({cell_key(s) for s in specs}) == len(specs)
    assert {s.severity for s in specs if s.noise == "clear"} == {0.0}


def test_same_results_with_one_or_two_workers(tmp_path):
    a = run_ablation(GRID, tmp_path / "a", workers=1, progress=False, cell_fn=stub_cell)
    b = run_ablation(GRID, tmp_path / "b", workers=2, progress=False, cell_fn=stub_cell)
    key = lambda rs: {cell_key(r): r["fnr"] for r in rs}  # noqa: E731
    assert key(a) == key(b) and len(a) == 90


def test_rerun_skips_done_cells_and_repairs_a_torn_line(tmp_path):
    out = tmp_path / "sweep"
    run_ablation(GRID, out, workers=1, progress=False, cell_fn=stub_cell)
    path = out / "results.jsonl"
    lines = path.read_text().splitlines()
    # Simulate a crash: the last row half-written, one row lost, one duplicated.
    path.write_text("\n".join(lines[:40] + [lines[10]] + [lines[41][: len(lines[41]) // 2]]))
    rerun = []

    def counting_cell(spec):
        rerun.append(cell_key(spec))
        return stub_cell(spec)

    records = run_ablation(GRID, out, workers=1, progress=False, cell_fn=counting_cell)
    kept = {cell_key(json.loads(line)) for line in lines[:40]}
    assert len(rerun) == 90 - 40 and kept.isdisjoint(rerun)  # only the lost cells rerun
    rows = _rows(path)
    assert len(rows) == 90 == len({cell_key(r) for r in rows}) == len(records)


@pytest.mark.parametrize("workers", [1, 2])
def test_failed_episode_is_recorded_and_the_sweep_goes_on(tmp_path, workers):
    grid = AblationGrid(scenarios=("racetrack",), noises=("clear",), filters=("none",), seeds=3, seed_start=12, steps=5)
    records = run_ablation(grid, tmp_path, workers=workers, progress=False, cell_fn=stub_cell)
    assert len(records) == 6
    failed = [r for r in records if r["error"]]
    assert len(failed) == 1
    row = failed[0]
    # the failing cell keeps its identity, says what went wrong, and scores nothing
    assert (row["seed"], row["driver"], row["filters"], row["severity"]) == (FAILING_SEED, FAILING_DRIVER, "none", 0.0)
    assert row["error"].startswith("RuntimeError: boom\n") and "stub_episode" in row["error"]
    assert row["steps"] == 0 and math.isnan(row["fnr"]) and math.isnan(row["driving_score"])
    # every other cell ran normally, and the file holds the same six rows
    assert all(r["error"] is None and r["steps"] == 5 for r in records if r is not row)
    assert {cell_key(r) for r in _rows(tmp_path / "results.jsonl")} == {cell_key(s) for s in grid.specs()}


def test_a_directory_with_another_grid_is_refused_unless_fresh(tmp_path):
    run_ablation(GRID, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    other = AblationGrid(scenarios=("winding",), noises=("clear",), filters=("none",), seeds=2, steps=5)
    with pytest.raises(SimroadError, match="different grid"):
        run_ablation(other, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    records = run_ablation(other, tmp_path, workers=1, progress=False, cell_fn=stub_cell, fresh=True)
    assert len(records) == 4 and len(_rows(tmp_path / "results.jsonl")) == 4


def test_a_grid_that_holds_the_old_one_grows_its_directory(tmp_path):
    """More filter sets, detectors and seeds join the results there; the old rows stay
    as they were and only the new cells run."""
    small = AblationGrid(scenarios=("racetrack",), noises=("clear", "rain"), filters=("none",), seeds=2, steps=5)
    run_ablation(small, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    before = (tmp_path / "results.jsonl").read_text()
    bigger = dataclasses.replace(small, filters=("none", "all"), seeds=3, detectors=("paper", EXAMPLE))
    assert bigger.grows(json.loads((tmp_path / "grid.json").read_text())["grid"])
    records = run_ablation(bigger, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    after = (tmp_path / "results.jsonl").read_text()
    assert after.startswith(before) and len(after.splitlines()) == len(records) == len(bigger.specs())
    assert {cell_key(r) for r in records} == {cell_key(s) for s in bigger.specs()}
    assert json.loads((tmp_path / "grid.json").read_text())["fingerprint"] == bigger.fingerprint()
    # run another way, or without some of the old cells: refused as before
    for other in (dataclasses.replace(bigger, steps=6), dataclasses.replace(bigger, filters=("all",)),
                  dataclasses.replace(bigger, env_options={"width": 160})):  # fmt: skip
        assert not other.grows(json.loads((tmp_path / "grid.json").read_text())["grid"])
        with pytest.raises(SimroadError, match="different grid"):
            run_ablation(other, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    assert not bigger.grows({"scenarios": "nowhere"})  # another version's grid.json


@pytest.mark.slow
def test_kill_minus_9_mid_sweep_then_rerun_gives_one_row_per_cell(tmp_path):
    out = tmp_path / "killed"
    script = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(HERE)!r})
        os.environ["SIMROAD_STUB_DELAY_S"] = "0.05"  # slow enough to be killed mid-sweep (workers read it)
        from stub_cell import stub_cell
        from simroad.experiments.ablate import run_ablation
        from simroad.experiments.grid import AblationGrid
        grid = AblationGrid(scenarios=("racetrack",), noises=("clear", "rain"), severities=(0.4, 0.8), filters=("none", "all"), seeds=10, steps=5)
        run_ablation(grid, {str(out)!r}, workers=2, progress=False, cell_fn=stub_cell)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True)
    path = out / "results.jsonl"
    deadline = time.time() + 60
    while time.time() < deadline and (not path.exists() or len(path.read_text().splitlines()) < 20):
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)  # the runner and its pool workers
    proc.wait()
    n_killed = len(path.read_text().splitlines())
    assert 20 <= n_killed < 90
    records = run_ablation(GRID, out, workers=2, progress=False, cell_fn=stub_cell)
    rows = _rows(path)
    keys = [cell_key(r) for r in rows]
    assert len(rows) == 90 and len(set(keys)) == 90 == len(records)
    assert set(keys) == {cell_key(s) for s in GRID.specs()}


def test_store_repair_keeps_valid_rows_only(tmp_path):
    store = ResultStore(tmp_path, log=lambda m: None)
    store.append(stub_cell(EpisodeSpec(scenario="racetrack", noise="clear", driver="oracle", seed=1, steps=5)))
    with open(store.path, "a") as fh:
        fh.write('{"scenario": "racetr')
    done = store.repair()
    assert len(done) == 1 and store.path.read_text().count("\n") == 1
    # the torn line is moved aside, not deleted
    (moved,) = _rows(tmp_path / "results.rejected.jsonl")
    assert moved["line"] == 2 and moved["text"] == '{"scenario": "racetr' and moved["reason"].startswith("torn")


def test_config_file_unknown_key_names_key_and_file(tmp_path):
    cfg = tmp_path / "grid.toml"
    cfg.write_text('scenarios = ["racetrack"]\nseedz = 3\n')
    with pytest.raises(SimroadError) as err:
        load_grid_file(cfg)
    assert "seedz" in str(err.value) and "grid.toml" in str(err.value) and "Did you mean 'seeds'" in str(err.value)


def test_a_config_saved_with_a_byte_order_mark_reads_like_one_without(tmp_path):
    text = 'scenarios = ["winding"]\nseeds = 2\n'
    plain, bom = tmp_path / "plain.toml", tmp_path / "bom.toml"
    plain.write_text(text, encoding="utf-8")
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert load_grid_file(bom) == load_grid_file(plain) == {"scenarios": ["winding"], "seeds": 2}


def test_a_config_that_is_not_utf8_is_refused_by_name(tmp_path):
    cfg = tmp_path / "latin1.toml"
    cfg.write_bytes('out = "runs/caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(SimroadError, match=r"latin1\.toml.*not valid TOML"):
        load_grid_file(cfg)


@pytest.mark.parametrize(
    "kw, name",
    [({"scenarios": "racetrak"}, "scenarios"), ({"noises": "rian"}, "noise"), ({"severities": "1.5"}, "severities"),
     ({"filters": "shadw"}, "filters"), ({"seeds": 0}, "seeds"), ({"scenarios": ""}, "scenarios")],
)  # fmt: skip
def test_invalid_grid_values_are_clear_errors(kw, name):
    with pytest.raises(SimroadError, match=name):
        AblationGrid(**kw)


@pytest.mark.parametrize("out", [5, None, ""])
def test_an_output_directory_that_is_not_a_path_is_refused_by_name(out):
    with pytest.raises(SimroadError, match=r"^out: expected a directory path"):
        run_ablation(GRID, out, workers=1, progress=False, cell_fn=stub_cell)  # was pathlib's TypeError


def test_grid_counts_given_as_integral_floats_or_numpy_integers_are_plain_ints():
    import numpy as np

    grid = AblationGrid(seeds=2.0, seed_start=np.int64(1), steps=np.int32(3))
    assert (grid.seeds, grid.seed_start, grid.steps) == (2, 1, 3)
    assert all(type(v) is int for v in (grid.seeds, grid.seed_start, grid.steps))
    assert sorted({s.seed for s in grid.specs()}) == [1, 2]  # seeds=2.0 raised range()'s TypeError
