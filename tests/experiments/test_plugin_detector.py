"""A user's detector in the closed loop: by file spec from the CLI and in Python, with the
real highway-env; records name what drove. (The worked example runs through ablate and
evaluate-detector in test_example_detector.py.)"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from simroad import SimroadError
from simroad.experiments.episode import EpisodeSpec, run_episode

pytestmark = pytest.mark.slow  # episodes with plug-in detectors, one in a fresh interpreter

ROOT = Path(__file__).resolve().parents[2]

DETECTOR = textwrap.dedent(
    """
    import numpy as np

    class Lower:
        name = "lower"
        version = "2.0"

        def __init__(self, fraction=0.5):
            self.fraction = fraction
            self.resets = 0

        def reset(self):
            self.resets += 1

        def predict(self, image):
            mask = np.zeros(image.shape[:2], bool)
            mask[int(image.shape[0] * (1 - self.fraction)):] = True
            return mask
    """
)


@pytest.fixture
def detector_file(tmp_path):
    path = tmp_path / "lower.py"
    path.write_text(DETECTOR)
    return path


def test_cli_episode_runs_a_detector_from_a_file(detector_file):
    cmd = [sys.executable, "-m", "simroad", "episode", "--scenario", "highway", "--steps", "8", "--json",
           "--detector", f"{detector_file}:Lower", "--detector-option", "fraction=0.3"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    record = json.loads(proc.stdout)
    assert (record["detector"], record["detector_version"]) == ("lower", "2.0")
    assert record["detector_spec"] == f"{detector_file}:Lower" and record["steps"] == 8
    assert record["fpr"] > 0 or record["fnr"] > 0  # a constant mask is scored, not the oracle's


def test_python_episode_resets_the_detector_and_oracle_has_none(detector_file):
    spec = EpisodeSpec(scenario="highway", steps=5, detector=f"{detector_file}:Lower", filters="shadow")
    record = run_episode(spec)
    assert record["detector"] == "lower" and record["filters"] == "shadow"
    from simroad.detector.registry import load_detector

    built = load_detector(spec.detector, filters=spec.filters)  # the one the episode used (cached)
    assert built.detector.resets == 1
    run_episode(spec)
    assert built.detector.resets == 2  # reset at every episode start
    oracle = run_episode(EpisodeSpec(scenario="highway", steps=5, driver="oracle"))
    assert (oracle["detector"], oracle["detector_spec"]) == ("", "")
    paper = run_episode(EpisodeSpec(scenario="highway", steps=5))
    assert paper["detector"] == "paper" and paper["detector_version"].startswith("simroad ")


def test_a_detector_that_returns_no_mask_is_named():
    class Broken:
        def predict(self, image):
            return np.zeros(3)

    with pytest.raises(SimroadError, match=r"detector 'Broken': predict\(\) returned shape \(3,\)"):
        run_episode(EpisodeSpec(scenario="highway", steps=2), detector=Broken())


def test_bad_detector_specs_fail_before_the_episode(tmp_path):
    cmd = [sys.executable, "-m", "simroad", "episode", "--steps", "2", "--detector", "nosuch"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 2 and "unknown detector 'nosuch'" in proc.stderr and "Traceback" not in proc.stderr
