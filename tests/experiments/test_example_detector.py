"""The worked example (examples/pixel_detector.py) through the command line's three
entry points, with the real highway-env (the fourth, Python, is examples/test_gate.py
and tests/experiments/test_ablate_real.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SPEC = "examples/pixel_detector.py:LabPixelDetector"
SMALL = ["--detector-option", "seeds=1", "--detector-option", "frames=1", "--detector-option", "samples=2000"]


def _run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "simroad", *args], capture_output=True, text=True, timeout=600, cwd=ROOT
    )


def test_example_in_an_episode():
    proc = _run(["episode", "--scenario", "town", "--steps", "6", "--json", "--detector", SPEC, *SMALL])
    assert proc.returncode == 0, proc.stderr
    record = json.loads(proc.stdout)
    assert (record["detector"], record["detector_version"]) == ("lab-pixels", "1")
    assert 1 <= record["steps"] <= 6 and record["detector_spec"] == SPEC  # (a tiny model may leave the road)


def test_example_in_a_sweep_beside_the_paper(tmp_path):
    small = [f"{SPEC}@{o}" if "=" in o else o for o in SMALL]
    proc = _run(["ablate", "--scenarios", "highway", "--noises", "clear", "--seeds", "1", "--steps", "4",
                 "--filters", "none", "--workers", "1", "--quiet", "--out", str(tmp_path),
                 "--detectors", f"paper,{SPEC}", *small])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text().splitlines()]
    assert sorted(r["detector"] for r in rows) == ["", "lab-pixels", "paper"]


def test_example_scored_on_held_out_frames():
    proc = _run(["evaluate-detector", "--scenario", "winding", "--seeds", "1", "--frames", "2", "--json",
                 "--filters", "none,rain_snow", "--detector", SPEC, *SMALL])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    rows = json.loads(proc.stdout)["detector"]
    assert [r["filters"] for r in rows] == ["none", "rain_snow"] and all(0.0 <= r["iou"] <= 1.0 for r in rows)
