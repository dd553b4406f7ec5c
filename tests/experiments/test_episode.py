"""Closed-loop episodes on the real highway-env with the real detector."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from simroad import SimroadError
from simroad.cli.main import main
from simroad.core.names import NOISE_NAMES
from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, _mask_record, run_episode
from simroad.experiments.gate import check_requirements, parse_requirement
from simroad.filters.pipeline import parse_filters
from simroad.metrics.mask import MaskScore

SHORT = 6


@pytest.mark.parametrize("scenario, noise", list(itertools.product(SCENARIO_NAMES, NOISE_NAMES)))
def test_short_headless_episode_of_every_scenario_and_noise(scenario, noise):
    spec = EpisodeSpec(
        scenario=scenario,
        noise=noise,
        severity=0.6,
        filters=("shadow", "rain_snow", "light"),
        steps=SHORT,
        seed=1,
        route_m=1e4,
    )
    rec = run_episode(spec)
    assert tuple(rec) == RECORD_KEYS
    # a car blinded by the weather may leave the road (the episode then ends early)
    assert 1 <= rec["steps"] <= SHORT and rec["noise"] == noise
    assert 0.0 <= rec["fnr"] <= 1.0 and 0.0 <= rec["fpr"] <= 1.0
    json.dumps(rec, allow_nan=False)  # strict JSON: no NaN or Infinity


def test_same_seed_same_record():
    spec = EpisodeSpec(scenario="winding", noise="rain", severity=0.5, steps=10, seed=3)
    a, b = run_episode(spec), run_episode(spec)
    timing = {"detect_ms_median", "step_ms_median", "wall_s"}
    assert {k: v for k, v in a.items() if k not in timing} == {k: v for k, v in b.items() if k not in timing}


def test_episode_ends_when_the_route_is_complete():
    rec = run_episode(EpisodeSpec(scenario="highway", driver="oracle", steps=100, traffic=False, route_m=60.0))
    assert rec["route_completion"] == 1.0 and rec["steps"] < 100


def test_oracle_has_perfect_mask_metrics():
    rec = run_episode(EpisodeSpec(scenario="racetrack", driver="oracle", steps=10))
    assert rec["fnr"] == 0.0 and rec["fpr"] == 0.0 and rec["iou"] == 1.0
    assert rec["fnr_image"] == 0.0 and rec["fpr_image"] == 0.0


def test_mask_record_by_hand_ground_and_whole_image():
    # 3x2 frame; the top row is sky (not ground). Truth: road at (1,0), (2,0), (2,1).
    valid = np.array([[0, 0], [1, 1], [1, 1]], bool)
    gt = np.array([[0, 0], [1, 0], [1, 1]], bool)
    pred = np.array([[1, 1], [1, 0], [0, 1]], bool)  # the sky called road, (2,0) missed
    ground, whole = MaskScore(), MaskScore()
    ground.update(pred, gt, valid=valid)
    whole.update(pred, gt)
    pred2 = np.array([[0, 0], [1, 1], [1, 1]], bool)  # a second frame: ground all road
    ground.update(pred2, gt, valid=valid)
    whole.update(pred2, gt)
    rec = _mask_record(ground, whole)
    # ground pixels: frame 1 tp 2 fn 1 fp 0 tn 1; frame 2 tp 3 fn 0 fp 1 tn 0
    assert rec["fnr"] == pytest.approx(1 / 6) and rec["fpr"] == pytest.approx(1 / 2)
    # per-frame means: FNR (1/3 + 0) / 2, FPR (0/1 + 1/1) / 2
    assert rec["fnr_frame_mean"] == pytest.approx(1 / 6) and rec["fpr_frame_mean"] == pytest.approx(1 / 2)
    # whole image adds the two sky pixels of each frame: frame 1 both called road (fp 2),
    # frame 2 none (tn 2): fp 1 + 2 = 3, tn 1 + 2 = 3 over the two frames
    assert rec["fnr_image"] == pytest.approx(1 / 6) and rec["fpr_image"] == pytest.approx(3 / 6)
    assert rec["iou"] == pytest.approx(5 / 7)  # ground: tp 5, fp 1, fn 1


@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
def test_ground_truth_is_non_road_where_the_camera_sees_no_ground(scenario):
    env = RoadCamEnv(scenario=scenario, noise="snow", severity=0.8)
    _, info = env.reset(seed=2)
    for _ in range(3):
        assert not info["road_mask"][~env.camera.ground_valid].any()
        _, _, _, _, info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    env.close()


class _SkyDetector:
    """Calls every pixel that is not ground road, and nothing else."""

    def __init__(self, ground_valid):
        self.mask = ~ground_valid

    def predict(self, image):
        return self.mask.copy()


def test_a_mask_that_calls_the_sky_road_costs_whole_image_fpr_only():
    spec = EpisodeSpec(scenario="highway", steps=4, traffic=False, route_m=1e4)
    sky = _SkyDetector(RoadCamEnv(scenario="highway").camera.ground_valid)
    rec = run_episode(spec, detector=sky)
    assert rec["fpr"] == 0.0 and rec["fnr"] == 1.0  # on the ground it calls nothing
    assert rec["fnr_image"] == 1.0 and rec["fpr_image"] > 0.2  # the sky is a large share of a frame


def test_custom_callable_driver():
    calls = []

    def policy(obs):
        calls.append(obs.shape)
        return np.array([0.0, 0.0], dtype=np.float32)

    rec = run_episode(EpisodeSpec(scenario="highway", steps=5, traffic=False, route_m=1e4), driver=policy)
    assert rec["driver"] == "custom" and len(calls) == 5


def test_require_gate_exit_codes(capsys):
    args = [
        "episode",
        "--scenario",
        "highway",
        "--driver",
        "oracle",
        "--steps",
        "5",
        "--route-m",
        "1000",
        "--no-traffic",
        "--json",
    ]
    assert main(args + ["--require", "offroad_fraction<=0.01"]) == 0
    assert main(args + ["--require", "fnr>0.5", "--require", "steps<3"]) == 1
    err = capsys.readouterr().err
    assert "fnr>0.5 violated: fnr = 0.0" in err and "steps<3 violated: steps = 5" in err


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_video_is_written(tmp_path, suffix):
    path = tmp_path / f"ep{suffix}"
    run_episode(EpisodeSpec(scenario="winding", noise="snow", steps=4), video=str(path))
    assert path.stat().st_size > 1000


@pytest.mark.parametrize(
    "args, needle",
    [(["--steps", "0"], "steps"), (["--driver", "orcale"], "Did you mean 'oracle'"), (["--filters", "shadw"], "filters"),
     (["--filters", "shadow+shadow"], "twice"), (["--require", "fnr=0.1"], "require"), (["--require", "fnn<0.1"], "Did you mean 'fnr'"),
     (["--video", "x.avi"], "video"), (["--noise", "rian"], "rain")],
)  # fmt: skip
def test_bad_input_exits_2(args, needle, capsys):
    assert main(["episode", "--steps", "2", *args]) == 2  # a later --steps overrides the first
    assert needle in capsys.readouterr().err


def test_parse_filters():
    assert parse_filters("none") == () and parse_filters("all") == ("shadow", "rain_snow", "light")
    assert parse_filters("light+shadow") == ("shadow", "light")
    with pytest.raises(SimroadError):
        parse_filters("all+shadow")


def test_requirement_parser():
    r = parse_requirement("offroad_fraction <= 0.01", valid_keys=RECORD_KEYS)
    assert check_requirements({"offroad_fraction": 0.0}, [r]) == []
    assert check_requirements({"offroad_fraction": 0.5}, [r]) == [
        "requirement offroad_fraction<=0.01 violated: offroad_fraction = 0.5"
    ]
    # min_ttc_s is None when nothing ever closed in: that is infinitely safe
    assert check_requirements({"min_ttc_s": None}, [parse_requirement("min_ttc_s>=2", valid_keys=RECORD_KEYS)]) == []


def test_route_and_time_limit_come_from_the_scenario_spec():
    from simroad.envs import RoadCamEnv, get_scenario
    from simroad.experiments.episode import default_route_m, scenario_route_m

    track = RoadCamEnv(scenario="racetrack", longitudinal=True)
    track.reset(seed=0)
    lap = scenario_route_m(track)
    assert lap != get_scenario("racetrack").route_m and 200.0 < lap < 2000.0  # one lap, measured
    assert default_route_m(track, 10_000) == lap
    road = RoadCamEnv(scenario="winding", longitudinal=True)
    road.reset(seed=0)
    spec = get_scenario("winding")
    assert scenario_route_m(road) == spec.route_m == 1000.0
    assert default_route_m(road, 10) == pytest.approx(0.8 * spec.cruise_speed_m_s * 10 * spec.policy_period_s)


def test_autopilot_rollout_helper_matches_stepping_by_hand():
    from simroad.control import autopilot_action
    from simroad.envs import RoadCamEnv
    from simroad.experiments.rollout import autopilot_env_action, drive_autopilot

    a, b = RoadCamEnv(scenario="winding", longitudinal=True), RoadCamEnv(scenario="winding", longitudinal=True)
    a.reset(seed=2)
    b.reset(seed=2)
    action = autopilot_env_action(a)
    assert action.dtype == np.float32 and action.shape == (2,) and action[1] == 0.0
    assert action[0] == np.float32(autopilot_action(a.highway_env.road, a.vehicle))
    obs_a, info_a = drive_autopilot(a, 3)
    for _ in range(3):
        obs_b, _, _, _, info_b = b.step(autopilot_env_action(b))
    np.testing.assert_array_equal(obs_a, obs_b)
    assert info_a["pose"].tolist() == info_b["pose"].tolist()
    with pytest.raises(SimroadError, match="steps"):
        drive_autopilot(a, 0)


def test_spec_stores_numpy_scalars_and_integral_floats_as_plain_numbers():
    spec = EpisodeSpec(seed=np.int64(2), steps=2.0, severity=np.float32(0.5), route_m=np.float32(50), noise="rain")
    assert (spec.seed, spec.steps, spec.severity, spec.route_m) == (2, 2, 0.5, 50.0)
    assert [type(v) for v in (spec.seed, spec.steps, spec.severity, spec.route_m)] == [int, int, float, float]
    rec = run_episode(EpisodeSpec(**{**vars(spec), "env_options": {"width": 64, "height": 48}}))
    json.dumps(rec)  # numpy scalars in the spec made the record unwritable


@pytest.mark.parametrize("driver", [5, None, ["oracle"]])
def test_spec_refuses_a_driver_that_is_neither_a_name_nor_a_callable(driver):
    with pytest.raises(SimroadError, match=r"^driver: unknown value"):
        EpisodeSpec(driver=driver)


@pytest.mark.parametrize("key", ["detector", "scenario", "noise", "filters", "driver", "detector_spec"])
def test_requirement_on_a_text_key_is_refused_before_the_episode(key):
    with pytest.raises(SimroadError, match=rf"^require: '{key}' is a text field of the record, not a number"):
        parse_requirement(f"{key}<=1", valid_keys=RECORD_KEYS)


@pytest.mark.parametrize("returned", ["left", {"steer": 0.1}, [0.1, "x"]])
def test_a_custom_driver_returning_no_numbers_is_refused_by_name(returned):
    from simroad.control import CallableDriver

    with pytest.raises(SimroadError, match=r"^driver: returned .*, expected an action"):
        CallableDriver(lambda obs: returned)(np.zeros((4, 4, 3), np.uint8), {})


def test_records_say_which_detector_options_and_env_options_ran():
    small = {"width": 160, "height": 90, "scenery": 0.0, "road_surface": "wet"}
    spec = EpisodeSpec(scenario="highway", steps=2, seed=4, detector_options={"morphology": False}, env_options=small)
    rec = run_episode(spec)
    assert rec["detector_options"] == {"morphology": False} and rec["env_options"] == small
    json.dumps(rec, allow_nan=False)
    other = run_episode(EpisodeSpec(scenario="highway", steps=2, seed=4, env_options=small))
    assert other["detector_options"] == {} and other["detector_spec"] == rec["detector_spec"]  # now told apart
    oracle = run_episode(EpisodeSpec(scenario="highway", steps=2, driver="oracle", detector_options={}))
    assert oracle["detector_options"] == {} and oracle["env_options"] == {}
