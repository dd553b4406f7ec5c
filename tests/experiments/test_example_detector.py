"""The worked example (examples/pixel_detector.py) through the command line's three
entry points, with the real highway-env (the fourth, Python, is examples/test_gate.py
and tests/experiments/test_ablate_real.py).

The commands run in this process (``main``, as tests/surface does), from the project
root where the relative spec points: the small example is trained once per filter set
and reused, as in any one sweep, instead of once per fresh interpreter.
(tests/cli/test_cli.py and tests/surface/test_end_to_end.py start real processes.)"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from simroad.cli.main import main

pytestmark = pytest.mark.slow  # trains the worked example, then episodes

ROOT = Path(__file__).resolve().parents[2]
SPEC = "examples/pixel_detector.py:LabPixelDetector"
SMALL = ["--detector-option", "seeds=1", "--detector-option", "frames=1", "--detector-option", "samples=2000"]


@pytest.fixture
def run(monkeypatch, capsys):
    """``run(args)``: ``simroad ARGS`` from the project root; (exit status, stdout, stderr)."""
    monkeypatch.chdir(ROOT)

    def run_(args: list[str]) -> tuple[int, str, str]:
        code = main(args)
        out, err = capsys.readouterr()
        return code, out, err

    return run_


def test_example_in_an_episode(run):
    code, out, err = run(["episode", "--scenario", "town", "--steps", "6", "--json", "--detector", SPEC, *SMALL])
    assert code == 0, err
    record = json.loads(out)
    assert (record["detector"], record["detector_version"]) == ("lab-pixels", "1")
    assert 1 <= record["steps"] <= 6 and record["detector_spec"] == SPEC  # (a tiny model may leave the road)


# With --filters none alone there is nothing to pair against "none": the report's
# paired.png has no series, and matplotlib warns of its empty legend (a subprocess hid it).
@pytest.mark.filterwarnings("ignore:No artists with labels found to put in legend:UserWarning")
def test_example_in_a_sweep_beside_the_paper(run, tmp_path):
    small = [f"{SPEC}@{o}" if "=" in o else o for o in SMALL]
    code, _, err = run(["ablate", "--scenarios", "highway", "--noises", "clear", "--seeds", "1", "--steps", "4",
                        "--filters", "none", "--workers", "1", "--quiet", "--out", str(tmp_path),
                        "--detectors", f"paper,{SPEC}", *small])  # fmt: skip
    assert code == 0, err
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text().splitlines()]
    assert sorted(r["detector"] for r in rows) == ["", "lab-pixels", "paper"]


def test_example_scored_on_held_out_frames(run):
    code, out, err = run(["evaluate-detector", "--scenario", "winding", "--seeds", "1", "--frames", "2", "--json",
                          "--filters", "none,rain_snow", "--detector", SPEC, *SMALL])  # fmt: skip
    assert code == 0, err
    rows = json.loads(out)["detector"]
    assert [r["filters"] for r in rows] == ["none", "rain_snow"] and all(0.0 <= r["iou"] <= 1.0 for r in rows)
