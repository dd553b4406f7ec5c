"""simroad/RoadCam-v0 against the gymnasium contract, on the real highway-env."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import simroad
from simroad import SimroadError
from simroad.camera import SKY
from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments.rollout import autopilot_env_action


@pytest.mark.slow
@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
def test_check_env_passes_without_a_warning(scenario):
    """gymnasium's checker reports most contract breaches as warnings, not errors:
    any warning fails the test."""
    env = gym.make(simroad.ENV_ID, scenario=scenario, render_mode="rgb_array")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    env.close()
    assert not caught, [f"{w.category.__name__}: {w.message}" for w in caught]


@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
def test_same_seed_identical_frames_and_truth(scenario):
    def rollout(seed):
        env = RoadCamEnv(scenario=scenario)
        obs, info = env.reset(seed=seed)
        out = [(obs, info["road_mask"])]
        for _ in range(4):
            obs, _, _, _, info = env.step(autopilot_env_action(env))
            out.append((obs, info["road_mask"]))
        env.close()
        return out

    a, b, c = rollout(7), rollout(7), rollout(8)
    for (oa, ma), (ob, mb) in zip(a, b):
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(ma, mb)
    assert any(not np.array_equal(oa, oc) for (oa, _), (oc, _) in zip(a, c))


def test_observation_and_info_contents():
    env = RoadCamEnv(scenario="racetrack", width=200, height=100)
    obs, info = env.reset(seed=0)
    assert obs.shape == (100, 200, 3) and obs.dtype == np.uint8
    assert env.observation_space.contains(obs)
    assert info["road_mask"].dtype == bool and info["road_mask"].shape == (100, 200)
    sky = info["material"] == SKY  # the sky is infinitely far; scenery may stand in the top row
    assert info["depth"].dtype == np.float32 and np.isinf(info["depth"][sky]).all() and sky[0].any()
    assert np.isfinite(info["depth"][~sky]).all()
    assert 0.2 < info["road_mask"].mean() < 0.8
    assert info["pose"].shape == (3,)
    assert abs(info["lateral_offset_m"]) < info["lane_width_m"] / 2
    _, reward, terminated, truncated, info = env.step(np.array([0.0], dtype=np.float32))
    assert reward == pytest.approx(info["rewards"]["total"])
    assert not terminated and not truncated


def test_longitudinal_action_has_two_components():
    env = RoadCamEnv(scenario="highway", longitudinal=True, traffic=False)
    assert env.action_space.shape == (2,)
    env.reset(seed=0)
    v0 = env.vehicle.speed
    for _ in range(3):
        _, _, _, _, info = env.step(np.array([0.0, 1.0], dtype=np.float32))
    assert info["speed_m_s"] > v0


def test_steering_turns_the_car_to_the_right():
    env = RoadCamEnv(scenario="highway", traffic=False)
    env.reset(seed=0)
    h0 = env.vehicle.heading
    for _ in range(3):
        env.step(np.array([0.5], dtype=np.float32))
    assert env.vehicle.heading > h0  # heading grows to the right in highway-env


@pytest.mark.slow
def test_autopilot_keeps_the_winding_road():
    env = RoadCamEnv(scenario="winding", traffic=False)
    env.reset(seed=3)
    offsets = []
    for _ in range(100):
        _, _, terminated, _truncated, info = env.step(autopilot_env_action(env))
        offsets.append(abs(info["lateral_offset_m"]))
        assert not terminated
    assert max(offsets) < 0.6


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec(mode):
    envs = gym.make_vec(simroad.ENV_ID, num_envs=2, vectorization_mode=mode, scenario="racetrack", width=64, height=36)
    obs, info = envs.reset(seed=[1, 2])
    assert obs.shape == (2, 36, 64, 3)
    assert info["road_mask"].shape == (2, 36, 64)
    obs, rew, _term, _trunc, info = envs.step(np.zeros((2, 1), dtype=np.float32))
    assert obs.shape == (2, 36, 64, 3) and rew.shape == (2,)
    envs.close()


def test_render_draws_the_gt_outline():
    env = RoadCamEnv(render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    img = env.render()
    assert img.shape == obs.shape and not np.array_equal(img, obs)
    rgb, road = env.render_bev()
    assert rgb.dtype == np.uint8 and rgb.shape == (320, 240, 3)
    assert road.dtype == np.bool_ and road.shape == (320, 240) and road.any() and not road.all()


def test_unknown_scenario_lists_valid_ones_with_suggestion():
    with pytest.raises(SimroadError) as err:
        RoadCamEnv(scenario="racetrak")
    msg = str(err.value)
    assert "scenario" in msg and "'highway'" in msg and "Did you mean 'racetrack'" in msg


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"width": 4000}, "width"),
        ({"height": 0}, "height"),
        ({"hfov_deg": 5}, "hfov_deg"),
        ({"pitch_deg": 60}, "pitch_deg"),
        ({"severity": 1.5}, "severity"),
    ],
)
def test_out_of_range_options_name_the_parameter(kw, name):
    with pytest.raises(SimroadError, match=name):
        RoadCamEnv(**kw)


def test_unknown_option_is_refused_with_suggestion():
    with pytest.raises(SimroadError, match="Did you mean 'width'"):
        RoadCamEnv(widht=100)


def test_bad_actions_are_clear_errors():
    env = RoadCamEnv()
    with pytest.raises(SimroadError, match="before reset"):
        env.step(np.zeros(1, dtype=np.float32))
    env.reset(seed=0)
    with pytest.raises(SimroadError, match="finite"):
        env.step(np.array([np.nan], dtype=np.float32))
    with pytest.raises(SimroadError, match="shape"):
        env.step(np.zeros(3, dtype=np.float32))


def test_config_and_keywords_together_are_refused():
    config = simroad.envs.RoadCamConfig(scenario="highway")
    with pytest.raises(SimroadError, match=r"config.*noise"):
        RoadCamEnv(config=config, noise="rain")
    with pytest.raises(SimroadError, match="RoadCamConfig"):
        RoadCamEnv(config={"scenario": "highway"})
    env = gym.make(simroad.ENV_ID, config=config)
    assert env.unwrapped.config is config


def test_reset_refuses_options():
    env = RoadCamEnv(scenario="highway", traffic=False)
    with pytest.raises(SimroadError, match=r"options.*'map'"):
        env.reset(seed=0, options={"map": 1})
    env.reset(seed=0, options={})  # empty options are fine


def test_all_state_exists_before_reset():
    env = RoadCamEnv(scenario="highway")
    fresh = set(vars(env))
    env.reset(seed=0)
    assert set(vars(env)) - fresh <= {"_np_random", "_np_random_seed"}
    with pytest.raises(SimroadError, match="reset"):
        RoadCamEnv().render_bev()


@pytest.mark.parametrize("seed", [np.int64(3), np.uint32(3), 3.0])
def test_reset_takes_a_numpy_or_integral_float_seed_as_that_integer(seed):
    env = RoadCamEnv(scenario="highway", width=64, height=48)
    obs, _ = env.reset(seed=seed)  # gymnasium refuses anything but a Python int
    ref, _ = RoadCamEnv(scenario="highway", width=64, height=48).reset(seed=3)
    np.testing.assert_array_equal(obs, ref)
