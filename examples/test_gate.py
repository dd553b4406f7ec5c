"""Gate a road detector in CI: short headless closed-loop episodes with the real
highway-env, thresholds on the episode records.

    pytest examples/test_gate.py
    SIMROAD_GATE_DETECTOR=my_pkg.detect:Model pytest examples/test_gate.py

The detector is any spec simroad takes (see simroad.detector.registry); the default is
the worked example next to this file. Each case is one episode of 60 policy steps on a
world the example never saw in training.
"""

import os
from pathlib import Path

import pytest

from simroad.experiments import EpisodeSpec, run_episode

pytestmark = pytest.mark.slow  # trains the worked example, then closed-loop episodes

DETECTOR = os.environ.get("SIMROAD_GATE_DETECTOR", f"{Path(__file__).with_name('pixel_detector.py')}:LabPixelDetector")

#: scenario, weather, severity, filters. (The worked example passes these; on the
#: winding road it leaves the road, in rain with or without the rain/snow filter: add
#: ("winding", "rain", 0.5, "rain_snow") to watch the gate fail.)
CASES = [("highway", "clear", 0.0, "none"), ("town", "clear", 0.0, "none")]

#: record key -> (largest, smallest) allowed value (None: no bound)
GATES = {
    "offroad_fraction": (0.05, None),
    "collided": (0, None),
    "fnr": (0.25, None),
    "route_completion": (None, 0.5),
}


@pytest.mark.parametrize(("scenario", "noise", "severity", "filters"), CASES)
def test_detector_keeps_the_car_on_the_road(scenario, noise, severity, filters):
    spec = EpisodeSpec(scenario=scenario, noise=noise, severity=severity, filters=filters, steps=60, seed=900,
                       detector=DETECTOR)  # fmt: skip
    record = run_episode(spec)
    failed = [
        f"{key} = {record[key]:.3g} (allowed {lo if lo is not None else '-inf'} .. {hi if hi is not None else 'inf'})"
        for key, (hi, lo) in GATES.items()
        if (hi is not None and record[key] > hi) or (lo is not None and record[key] < lo)
    ]
    assert not failed, f"{record['detector']} on {scenario}/{noise} {severity}: " + "; ".join(failed)
