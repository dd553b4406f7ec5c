"""Shared fixtures and the ``slow`` marks. Everything runs headless (simroad sets SDL's dummy driver)."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np
import pytest

#: Tests over ~10 s on 2 cores (measured with ``pytest -n 2 --durations=40``), marked
#: ``slow`` by node-id prefix so that ``make test-fast`` (``-m "not slow"``) stays under
#: a minute; ``make test`` runs them all. A test may also carry ``@pytest.mark.slow``
SLOW = (
    "tests/experiments/test_closed_loop_acceptance.py::",
    "tests/experiments/test_ablate_real.py::",
    "tests/experiments/test_plugin_detector.py::",
    "examples/test_gate.py::",
    "tests/experiments/test_example_detector.py::",
    "tests/experiments/test_robustness.py::",
    "tests/experiments/test_filter_effect.py::test_light_filter_lowers_fnr_plus_fpr_under_strong_glare",
    "tests/experiments/test_filter_effect.py::test_paper_light_filter_leaves_grey_asphalt_glare_in_place",
    "tests/experiments/test_filter_effect.py::test_improved_rain_snow_filter_lifts_the_snow_veil",
    "tests/experiments/test_filter_effect.py::test_table_rows_and_format",
    "tests/detector/test_detector.py::test_pretrained_model_meets_clean_frame_targets_in_every_scenario",
    "tests/detector/test_detector.py::test_nonroad_weight_trades_false_road_for_missed_road",
    "tests/detector/test_detector.py::test_train_default_is_reproducible",
    "tests/envs/test_roadcam.py::test_check_env_passes",
    "tests/envs/test_roadcam.py::test_autopilot_keeps_the_winding_road",
    "tests/camera/test_ground_truth.py::test_road_mask_agrees_with_lane_geometry",
    "tests/control/test_lane_keeping.py::test_oracle_keeps_its_lane",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    root = config.rootpath
    for item in items:
        nodeid = item.nodeid
        if not nodeid.startswith(("tests/", "examples/")):  # run from another directory: relative to the root
            nodeid = os.path.relpath(str(item.path), root).replace(os.sep, "/") + "::" + item.name
        if nodeid.startswith(SLOW):
            item.add_marker(pytest.mark.slow)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
