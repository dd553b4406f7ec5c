"""The worked example (examples/pixel_detector.py) through the command line's three
entry points, with the real highway-env (the fourth, Python, is examples/test_gate.py
and tests/experiments/test_ablate_real.py).

The commands run in this process (``main``, as tests/surface does), from the project
root where the relative spec points: the small example is trained once per filter set
and reused, as in any one sweep, instead of once per fresh interpreter.
(tests/cli/test_cli.py and tests/surface/test_end_to_end.py start real processes.)"""

from __future__ import annotations

import json
import math
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


@pytest.mark.filterwarnings("error")  # no warning from the report (an empty legend warned before)
def test_example_head_to_head_with_the_paper(run, tmp_path):
    """`ablate --detectors paper,<example> --filters none`: a paired "lab-pixels − paper"
    row per cell, with its interval, in summary.md, paired.csv and paired.json; no
    column of the at-a-glance table is empty; paired.png draws it."""
    small = [f"{SPEC}@{o}" if "=" in o else o for o in SMALL]
    code, _, err = run(["ablate", "--scenarios", "highway", "--noises", "clear,rain", "--severities", "0.6",
                        "--seeds", "2", "--steps", "4", "--filters", "none", "--workers", "1", "--quiet",
                        "--out", str(tmp_path), "--detectors", f"paper,{SPEC}", *small])  # fmt: skip
    assert code == 0 and err == "", err
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text().splitlines()]
    assert sorted(r["detector"] for r in rows) == ["", "", "", "", *["lab-pixels"] * 4, *["paper"] * 4]
    label = "lab-pixels − paper"
    paired = json.loads((tmp_path / "paired.json").read_text())
    versus = [p for p in paired if p["comparison"] == "detectors"]
    assert {(p["noise"], p["scenario"]) for p in versus} == {("clear", "all"), ("rain", "all"), ("clear", "highway"),
                                                            ("rain", "highway")}  # fmt: skip
    for p in versus:
        assert (p["detector"], p["baseline"], p["setting"], p["pairs"]) == (label, "paper", "none", 2)
        lo, mid, hi = p["driving_score_diff_lo"], p["driving_score_diff"], p["driving_score_diff_hi"]
        assert lo <= mid <= hi and math.isfinite(lo) and math.isfinite(hi)
        mine = [r for r in rows if r["detector"] == "lab-pixels" and r["noise"] == p["noise"]]
        ref = [r for r in rows if r["detector"] == "paper" and r["noise"] == p["noise"]]
        by_seed = {r["seed"]: r["driving_score"] for r in ref}
        assert mid == pytest.approx(sum(r["driving_score"] - by_seed[r["seed"]] for r in mine) / 2)
    csv = (tmp_path / "paired.csv").read_text()
    assert csv.count(label) == 4 and "comparison" in csv.splitlines()[0]
    summary = (tmp_path / "summary.md").read_text()
    section = summary.split("## Detector vs detector, paired")[1].split("## Per cell")[0]
    assert section.count(f"| {label} |") == 2  # clear and rain 0.6, pooled over scenarios
    glance = summary.split("## At a glance")[1].split("## Filters vs none")[0]
    table = [line for line in glance.splitlines() if line.startswith("|") and "---" not in line]
    head, body = table[0], table[1:]
    assert f"driving score {label} (none), paired" in head and "all − none" not in head
    assert len(body) == 2 and all("| – |" not in line and "/ – " not in line for line in body)
    assert (tmp_path / "paired.png").stat().st_size > 10_000


def test_example_scored_on_held_out_frames(run):
    code, out, err = run(["evaluate-detector", "--scenario", "winding", "--seeds", "1", "--frames", "2", "--json",
                          "--filters", "none,rain_snow", "--detector", SPEC, *SMALL])  # fmt: skip
    assert code == 0, err
    rows = json.loads(out)["rows"]
    assert [r["filters"] for r in rows] == ["none", "rain_snow"] and all(0.0 <= r["iou"] <= 1.0 for r in rows)
