"""ControllerConfig: every tunable validated by name, defaults pinned, scenario priors from the spec."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simroad import SimroadError
from simroad.control import ControllerConfig, MaskDriver, make_driver
from simroad.envs import SCENARIOS, RoadCamEnv, get_scenario

#: The numbers every published result was driven with: changing one changes trajectories.
PINNED = {
    "lane_width_m": 3.5,
    "lookaheads_m": (5.0, 6.0, 7.0, 9.0, 11.0, 13.0, 15.0, 18.0, 21.0, 25.0, 30.0, 36.0),
    "lookahead_time_s": 0.9,
    "min_lookahead_m": 6.0,
    "max_lookahead_m": 25.0,
    "target_speed_m_s": 10.0,
    "max_decel_m_s2": 4.0,
    "max_accel_m_s2": 3.0,
    "speed_gain_1_s": 1.5,
    "stop_margin_m": 6.0,
    "free_road_max_m": 90.0,
    "free_road_step_m": 5.0,
    "row_match_tolerance": 0.25,
    "corridor_half_width_m": 1.1,
    "corridor_min_road": 0.8,
    "max_lateral_accel_m_s2": 2.0,
    "wheelbase_m": 5.0,
    "bridge_gap_m": 0.6,
    "max_run_offset_m": 3.0,
    "occlusion_tolerance_m": 0.6,
    "occlusion_tolerance_per_m": 0.05,
    "path_jump_max_m": 1.0,
    "coast_frames": 2,
    "quadratic_min_points": 4,
    "quadratic_min_span_m": 4.0,
    "line_min_span_m": 1.0,
    "outlier_min_m": 0.5,
    "outlier_mad_factor": 3.0,
    "fit_rounds": 3,
    "edge_steps_m": (),
    "grip_use": 0.6,
}


def test_defaults_are_pinned():
    assert dataclasses.asdict(ControllerConfig()) == PINNED


@pytest.mark.parametrize("field", [f.name for f in dataclasses.fields(ControllerConfig)])
def test_every_field_is_validated_by_name(field):
    bad = {"lookaheads_m": (5.0,), "quadratic_min_points": 2, "fit_rounds": 0}.get(field, -1.0)
    with pytest.raises(SimroadError, match=field):
        ControllerConfig(**{field: bad})


def test_cross_field_and_type_checks():
    with pytest.raises(SimroadError, match="min_lookahead_m"):
        ControllerConfig(min_lookahead_m=30.0, max_lookahead_m=20.0)
    with pytest.raises(SimroadError, match="lookaheads_m"):
        ControllerConfig(lookaheads_m="5,10")  # type: ignore[arg-type]
    with pytest.raises(SimroadError, match="lookahead_time_s"):
        ControllerConfig(lookahead_time_s="fast")  # type: ignore[arg-type]
    assert ControllerConfig(lookaheads_m=[5, 10]).lookaheads_m == (5.0, 10.0)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_for_scenario_takes_lane_width_and_cruise_speed_from_the_spec(name):
    spec = get_scenario(name)
    cfg = ControllerConfig.for_scenario(spec)
    assert cfg.lane_width_m == spec.lane_width_m and cfg.target_speed_m_s == spec.cruise_speed_m_s
    assert ControllerConfig.for_scenario(spec, max_decel_m_s2=6.0).max_decel_m_s2 == 6.0
    with pytest.raises(SimroadError, match="scenario"):
        ControllerConfig.for_scenario(name)  # type: ignore[arg-type]


def test_parking_strips_become_edge_steps():
    assert ControllerConfig.for_scenario(get_scenario("town")).edge_steps_m == (2.3,)
    assert ControllerConfig.for_scenario(get_scenario("winding")).edge_steps_m == ()


def test_mask_driver_takes_camera_and_config_explicitly():
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    obs, info = env.reset(seed=0)
    cfg = ControllerConfig.for_scenario(get_scenario("highway"))
    explicit = MaskDriver(env.camera, cfg)
    convenient = make_driver("oracle", env)
    np.testing.assert_array_equal(explicit(obs, info), convenient(obs, info))
    with pytest.raises(SimroadError, match="camera"):
        MaskDriver(env, cfg)  # type: ignore[arg-type]
    with pytest.raises(SimroadError, match="control"):
        MaskDriver(env.camera, {"lane_width_m": 4.0})  # type: ignore[arg-type]


def test_mask_driver_starts_the_detector_with_its_camera_every_episode():
    calls = []

    class Recorder:
        def predict(self, image):
            return np.ones(image.shape[:2], bool)

        def reset(self):
            calls.append("reset")

        def set_camera(self, camera):
            calls.append(camera)

    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    driver = make_driver("detector", env, detector=Recorder())
    for seed in (0, 1):
        env.reset(seed=seed)
        driver.reset()
    assert calls == ["reset", env.camera, "reset", env.camera]
    # the paper's detector behind the filters hears of it too
    from simroad.detector.registry import FilteredDetector

    inner = Recorder()
    make_driver("detector", env, detector=FilteredDetector(inner, ("shadow",))).reset()
    assert calls[-1] is env.camera
