"""A detector that fails is loud: a sweep stops before its first episode when a detector
cannot predict one frame, names a detector that fails later in summary.md with its
cells, and the command line's exit status tells a failure (3) from a missed gate (1)."""

from __future__ import annotations

import json
import textwrap

import pytest

from simroad.cli.main import EXIT_CODES, main
from simroad.errors import DetectorFailedError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid

PLUGINS = textwrap.dedent(
    """
    import numpy as np

    class WrongShape:
        def predict(self, image):
            return np.zeros((4, 4), bool)

    class Raises:
        def predict(self, image):
            raise KeyError("weights")

    class LateCrash:
        '''Predicts the first two frames of an episode, then raises.'''
        def __init__(self):
            self.n = 0
        def reset(self):
            self.n = 0
        def predict(self, image):
            self.n += 1
            if self.n >= 3:
                raise RuntimeError("late failure")
            return np.ones(image.shape[:2], bool)
    """
)


@pytest.fixture
def plugins(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(PLUGINS)
    return str(path)


def _ablate(out, detectors):
    return ["ablate", "--scenarios", "highway", "--noises", "clear", "--filters", "none", "--seeds", "2", "--steps",
            "4", "--workers", "1", "--detectors", detectors, "--out", str(out), "--quiet"]  # fmt: skip


@pytest.mark.parametrize(("cls", "words"), [("WrongShape", "returned shape (4, 4)"), ("Raises", "raised KeyError")])
def test_a_detector_that_cannot_predict_one_frame_stops_the_sweep_before_any_episode(
    plugins, tmp_path, capsys, cls, words
):
    out = tmp_path / "sweep"
    assert main(_ablate(out, f"paper,{plugins}:{cls}")) == 3
    err = capsys.readouterr().err
    assert f"mine.py:{cls}" in err and words in err and "before the sweep started" in err and "Traceback" not in err
    assert not (out / "results.jsonl").exists() or (out / "results.jsonl").read_text() == ""
    grid = AblationGrid(scenarios=("highway",), noises=("clear",), filters=("none",), seeds=1, steps=2, oracle=False,
                        detectors=(f"{plugins}:{cls}",))  # fmt: skip
    with pytest.raises(DetectorFailedError, match=cls):
        run_ablation(grid, tmp_path / "py", workers=1, progress=False)


def test_a_detector_that_fails_later_is_named_with_its_cells(plugins, tmp_path, capsys):
    out = tmp_path / "sweep"
    assert main(_ablate(out, f"paper,{plugins}:LateCrash")) == 3
    err = capsys.readouterr().err
    assert "LateCrash" in err and "2 of 2 episodes failed" in err and "late failure" in err
    summary = (out / "summary.md").read_text()
    section = summary.split("## Failed episodes (2)")[1]
    assert "LateCrash" in section and "2 of 2 failed (every one)" in section
    assert "highway/clear/0/seed 0" in section and "highway/clear/0/seed 1" in section and "late failure" in section
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    failed = sorted(r["detector_spec"].rsplit(":", 1)[-1] for r in rows if r["error"])
    assert len(rows) == 6 and failed == ["LateCrash", "LateCrash"]  # the oracle and paper ran


def test_episode_tells_a_failed_detector_from_a_missed_gate(plugins, capsys):
    base = ["episode", "--scenario", "highway", "--steps", "4", "--json"]
    assert main([*base, "--detector", f"{plugins}:LateCrash"]) == 3
    err = capsys.readouterr().err
    assert "a detector failed" in err and "late failure" in err and "Traceback" not in err
    assert main([*base, "--require", "fnr<=-1"]) == 1  # ran, and missed the gate
    assert main([*base]) == 0
    assert set(EXIT_CODES) == {0, 1, 2, 3, 130}
