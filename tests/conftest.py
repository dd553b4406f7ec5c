"""Shared fixtures, the ``slow`` marks, and with ``-n`` the order and grouping of the tests
across xdist workers. Everything runs headless (simroad sets SDL's dummy driver)."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np
import pytest

#: Tests over ~10 s on 2 cores (measured with ``pytest -n 2 --durations=40``), marked
#: ``slow`` by node-id prefix so that ``make test-fast`` (``-m "not slow"``) stays near
#: two minutes (2026-12-02: 2:07, no test over 7 s); ``make test`` runs them all. A test
#: may also carry ``@pytest.mark.slow``
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


#: The longest tests, longest first (CPU seconds on 2 busy cores, measured with
#: ``pytest -n 2 --durations=60``). They run first: with ``-n`` the tests are handed out one
#: at a time in this order to whichever worker is free (:class:`_LongestFirst`), so the
#: short tests fill in around the long ones instead of a long one starting last and
#: running alone at the end.
LONGEST_FIRST = (
    "tests/soak/test_soak.py::test_rss_flat_over_100_resets_after_warm_up",  # 80-100 s (120 resets)
    "tests/detector/test_detector.py::test_pretrained_model_meets_clean_frame_targets_in_every_scenario",  # 55-65 s
    "tests/detector/test_detector.py::",  # 50 s with test_lut.py (one group)
    "examples/test_gate.py::",  # 40 s (trains the worked example)
    "tests/soak/test_soak.py::test_rss_flat_over_a_2000_step_detector_episode",  # 40-45 s
    "tests/experiments/test_ablate_real.py::",  # 40 s and two Ray workers
    "tests/camera/test_scenery.py::",  # 35 s
    "tests/experiments/test_ray_cluster.py::test_node_killed_mid_sweep",  # 25 s and two Ray nodes
    "tests/experiments/test_filter_effect.py::",  # 30 s
    "tests/experiments/test_closed_loop_acceptance.py::",  # 16 episodes of 7-15 s
    "tests/experiments/test_example_detector.py::",  # 3 x 4-7 s
    "tests/experiments/test_training.py::",  # 15 s
    "tests/soak/test_soak.py::",  # 15 s
    "tests/envs/test_roadcam.py::test_check_env_passes",  # 4 x 8-13 s
    "tests/experiments/test_figures.py::",  # 12-15 s
    "tests/envs/test_town.py::test_oracle_drives_the_town_route",  # 2 x 8-11 s
    "tests/camera/test_realism.py::",  # 4 x 6-9 s
)

#: Tests that share expensive in-process work, by node-id prefix (the first that matches;
#: None: a test of its own). Each group runs on one worker, so the work is done once:
#: a module fixture, tests/detector/conftest.py's session fixtures (rendered frames, a
#: trained detector), load_detector's per-process cache of the trained worked example.
SHARED = (
    ("tests/detector/test_detector.py::test_pretrained_model_meets_clean_frame_targets_in_every_scenario", None),
    ("tests/detector/test_detector.py::", "detector-frames"),
    ("tests/detector/test_lut.py::", "detector-frames"),
    ("examples/test_gate.py::", "example-detector"),
    ("tests/experiments/test_ablate_real.py::", "ablate-real"),
    ("tests/experiments/test_filter_effect.py::", "filter-effect"),
    ("tests/experiments/test_robustness.py::", "robustness-photos"),
    ("tests/camera/test_scenery.py::", "scenery-worlds"),
)


def _rank(nodeid: str) -> int:
    return next((k for k, prefix in enumerate(LONGEST_FIRST) if nodeid.startswith(prefix)), len(LONGEST_FIRST))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    root = config.rootpath
    rank = {}
    for item in items:
        nodeid = item.nodeid
        if not nodeid.startswith(("tests/", "examples/")):  # run from another directory: relative to the root
            nodeid = os.path.relpath(str(item.path), root).replace(os.sep, "/") + "::" + item.name
        if nodeid.startswith(SLOW):
            item.add_marker(pytest.mark.slow)
        rank[item] = _rank(nodeid)
    items.sort(key=rank.__getitem__)  # stable: the rest keep their order


class _XdistHooks:
    """xdist's scheduler hook, registered only where xdist is loaded (``-p no:xdist``
    runs would otherwise stop on an unknown hook)."""

    @staticmethod
    def pytest_xdist_make_scheduler(config: pytest.Config, log):
        """With ``-n`` (xdist's default ``--dist load``): longest first, one test or one
        :data:`SHARED` group at a time. (pytest 9 ignores the node ids that xdist's own
        ``--dist loadgroup`` rewrites to group tests.)"""
        if config.getvalue("dist") != "load":
            return None  # another --dist asked for by name
        from xdist.scheduler import LoadScopeScheduling

        class _LongestFirst(LoadScopeScheduling):
            """One test at a time, or one :data:`SHARED` group, in the collection's order to
            whichever worker has at most two left (xdist's ``loadscope`` with our scopes)."""

            def _split_scope(self, nodeid: str) -> str:
                group = next((g for prefix, g in SHARED if nodeid.startswith(prefix)), None)
                return group or nodeid

        config.option.loadscopereorder = False  # keep the longest-first order
        return _LongestFirst(config, log)


def pytest_configure(config: pytest.Config) -> None:
    if config.pluginmanager.hasplugin("xdist"):
        config.pluginmanager.register(_XdistHooks(), "simroad-xdist-scheduler")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
