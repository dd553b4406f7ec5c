"""Recorded renders exposed again (the calibration's evaluation): the same frames as
the environment's own where nothing is drawn, close statistics where the camera
changes, the same recordings from worker processes, and a scene render that draws nothing."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.camera.profile import CameraProfile
from simroad.camera.sensor_params import SensorParams
from simroad.envs import RoadCamEnv
from simroad.errors import InvalidParameterError
from simroad.experiments.calibrate import profile_statistics
from simroad.experiments.frames import collect_frames
from simroad.experiments.replay import record_world, record_worlds, replay_frames, replay_statistics
from simroad.experiments.rollout import autopilot_env_action

#: A sensor that draws nothing (no noise, no white-balance error) and a profile without
#: the meter's scene bias: replayed frames must then be the environment's, bit for bit.
QUIET = {
    "camera_effects": SensorParams(shot_noise=False, read_noise_e=0.0, wb_error_mired=0.0, white_balance_error=0.0)
}
PROFILE = CameraProfile(exposure_spread_ev=0.0, exposure_bias_ev=0.5, asphalt_scale=1.2)
WORLDS = {"scenarios": ("highway", "town"), "seeds": (11, 12)}


@pytest.fixture(scope="module")
def recorded():
    return record_worlds(PROFILE, **WORLDS, frames=2, every=5, env_options=QUIET)


@pytest.mark.slow
def test_replayed_frames_are_the_environments_own_when_nothing_is_drawn(recorded):
    replayed = list(replay_frames(recorded, PROFILE, env_options=QUIET))
    fs = collect_frames(**WORLDS, frames_per_seed=3, every=5, env_options={**QUIET, "camera_profile": PROFILE})
    own = [(src, rgb) for src, rgb in zip(fs.source, fs.images) if src[2] > 0]
    assert len(replayed) == len(own) == 8
    for (rec, step, frame), (src, rgb) in zip(replayed, own):
        assert (rec.scenario, rec.seed, step) == src
        np.testing.assert_array_equal(frame, rgb)


@pytest.mark.slow
def test_a_replayed_camera_gives_the_statistics_of_a_render_with_it(recorded):
    """Only the ground's motion blur stays the recording's: the statistics agree with a
    full render's to well within the spread between worlds."""
    other = CameraProfile(exposure_spread_ev=0.0, exposure_bias_ev=-0.5, tone_gamma=1.3, asphalt_scale=1.2)
    replayed = replay_statistics(recorded, other, env_options=QUIET)
    rendered = profile_statistics(other, **WORLDS, frames=2, env_options=QUIET)
    original = replay_statistics(recorded, PROFILE, env_options=QUIET)
    assert replayed["road_V"].size == rendered["road_V"].size == 8
    for s in ("road_V", "frame_V", "road_S", "road_spread"):
        np.testing.assert_allclose(replayed[s], rendered[s], atol=0.01, err_msg=s)
    assert np.all(replayed["road_V"] < original["road_V"] - 0.03)  # and the camera did change them


@pytest.mark.slow
def test_workers_record_the_same_worlds_in_the_same_order(recorded):
    again = record_worlds(PROFILE, **WORLDS, frames=2, every=5, env_options=QUIET, workers=2)
    assert [(r.scenario, r.seed) for r in again] == [(r.scenario, r.seed) for r in recorded]
    for a, b in zip(again, recorded):
        assert a.kept.keys() == b.kept.keys() and len(a.steps) == len(b.steps) == 11
        for (rgb_a, *_), (rgb_b, *_) in zip(a.steps, b.steps):
            np.testing.assert_array_equal(rgb_a, rgb_b)


def test_recording_without_a_sensor_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match="camera_effects=False leaves no sensor"):
        record_world(("highway", 1, PROFILE, 1, 5, {"camera_effects": False}))


def test_rendering_the_scene_draws_nothing():
    a, b = RoadCamEnv(scenario="town"), RoadCamEnv(scenario="town")
    a.reset(seed=4)
    b.reset(seed=4)
    for _ in range(3):
        first, second = a.render_scene(motion_m=0.1), a.render_scene(motion_m=0.1)
        np.testing.assert_array_equal(first.rgb, second.rgb)
        np.testing.assert_array_equal(first.road_mask, second.road_mask)
        obs_a = a.step(autopilot_env_action(a))[0]
        obs_b = b.step(autopilot_env_action(b))[0]
        np.testing.assert_array_equal(obs_a, obs_b)
