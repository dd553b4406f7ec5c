"""Real sweeps (highway-env, the paper's detector and the worked example's): the same
numbers on every backend."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from simroad.cli.main import main
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid, cell_key

pytestmark = pytest.mark.slow  # a real sweep on two Ray workers

#: The worked example's detector (examples/pixel_detector.py), trained small for the test.
EXAMPLE = f"{Path(__file__).resolve().parents[2] / 'examples' / 'pixel_detector.py'}:LabPixelDetector"
GRID = AblationGrid(
    scenarios=("winding",), noises=("rain",), severities=(0.6,), filters=("none", "all"), seeds=1, steps=6,
    detectors=("paper", EXAMPLE), detector_options={EXAMPLE: {"seeds": 1, "frames": 1, "samples": 2000}},
)  # fmt: skip
TIMING = {"detect_ms_median", "step_ms_median", "wall_s"}


def _metrics(records):
    return {cell_key(r): {k: v for k, v in r.items() if k not in TIMING} for r in records}


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory):
    return run_ablation(GRID, tmp_path_factory.mktemp("w1"), workers=1, progress=False)


def test_grid_runs_and_nothing_fails(one_worker):
    # winding x rain 0.6 x 1 seed x (oracle + 2 detectors x 2 filter sets)
    assert len(one_worker) == 5 and not any(r["error"] for r in one_worker)
    assert sorted({r["detector"] for r in one_worker}) == ["", "lab-pixels", "paper"]


def test_two_workers_give_identical_metrics(one_worker, tmp_path):
    two = run_ablation(GRID, tmp_path, workers=2, progress=False)
    assert _metrics(two) == _metrics(one_worker)


@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="Ray not installed (pip install 'simroad[ray]')")
def test_ray_backend_gives_identical_metrics(one_worker, tmp_path):
    ray_records = run_ablation(GRID, tmp_path, workers=2, backend="ray", progress=False)
    assert _metrics(ray_records) == _metrics(one_worker)


def test_cli_ablate_writes_results_and_reports(tmp_path):
    out = tmp_path / "cli"
    code = main(["ablate", "--scenarios", "highway", "--noises", "clear,shadow", "--severities", "0.8", "--filters", "none,shadow",
                 "--seeds", "2", "--steps", "4", "--workers", "1", "--out", str(out), "--quiet"])  # fmt: skip
    assert code == 0
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert len(rows) == (1 + 1) * 2 * 3
    for name in ("summary.csv", "summary.md", "error_rates.png", "safety.png"):
        assert (out / name).stat().st_size > 100
    assert main(["report", str(out)]) == 0


def test_cli_empty_grid_and_bad_values_fail_before_any_episode(tmp_path, capsys):
    out = tmp_path / "bad"
    assert main(["ablate", "--scenarios", "", "--out", str(out), "--quiet"]) == 2
    assert main(["ablate", "--severities", "0.5,nan", "--out", str(out), "--quiet"]) == 2
    assert main(["ablate", "--backend", "dask", "--out", str(out), "--quiet"]) == 2
    assert not (out / "results.jsonl").exists()
    err = capsys.readouterr().err
    assert "scenarios" in err and "severities" in err and "backend" in err
