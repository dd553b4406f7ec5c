"""The public Python surface, walked whole: every field of the typed
configs and every public function of simroad.envs, .noise, .control, .metrics and
.experiments (plus the filters' and detector's existing checks), each given a wrong
type, an out-of-range value and, where a file is read, a malformed file. Each must
raise a SimroadError (a ValueError) or a TypeError/ValueError whose message names the
parameter -- never an error from deep inside NumPy, OpenCV or gymnasium.

Config cases are generated from the dataclass fields (and ``Params.LIMITS``), so a new
field is covered automatically; a field of a type with no generator, or a public name
with no case and no stated exemption, fails a registry test.
"""

from __future__ import annotations

import dataclasses
import importlib

import gymnasium as gym
import numpy as np
import pytest

import simroad  # noqa: F401  (registers the environment)
from simroad import control, envs, experiments, filters, metrics, noise
from simroad.camera.geometry import CameraConfig
from simroad.camera.profile import CameraProfile
from simroad.camera.sensor_params import SensorParams
from simroad.control import ControllerConfig
from simroad.core import radiometry
from simroad.envs import RoadCamConfig
from simroad.errors import SimroadError
from simroad.experiments import AblationGrid, EpisodeSpec
from simroad.metrics import safety
from simroad.noise import MODELS, WindscreenParams

PARAMS = [*(m.params_type for m in MODELS.values()), WindscreenParams]
CONFIGS = [
    RoadCamConfig,
    CameraConfig,
    CameraProfile,
    SensorParams,
    EpisodeSpec,
    AblationGrid,
    ControllerConfig,
    *PARAMS,
]


def _refused(fn, name: str) -> None:
    """``fn()`` raises a SimroadError (an InvalidParameterError is also a ValueError and a
    TypeError; ResetNeededError a RuntimeError) or a ValueError/TypeError naming ``name``."""
    with pytest.raises((SimroadError, ValueError, TypeError)) as exc:
        fn()
    assert name in str(exc.value), f"the message does not name {name!r}: {exc.value}"
    assert isinstance(exc.value, SimroadError) or type(exc.value) in (ValueError, TypeError)


# -- typed configs: every dataclass field ------------------------------------------

_BY_TYPE: dict[str, list[tuple[str, object]]] = {
    "int": [("wrong type", "3x"), ("below range", -(10**12)), ("above range", 10**12)],
    "float": [("wrong type", "x"), ("below range", -1e12), ("above range", 1e12), ("not finite", float("nan"))],
    "float | None": [("wrong type", "x"), ("above range", 1e12)],
    "int | None": [("wrong type", "x"), ("above range", 10**12)],
    "bool | SensorParams": [("string boolean", "on"), ("integer 2", 2)],
    "bool | WindscreenParams": [("string boolean", "on"), ("integer 2", 2)],
    "float | str | None": [("wrong type", [1.0]), ("unknown name", "bogus"), ("above range", 1e12)],
    "bool": [("string boolean", "no"), ("integer 2", 2)],
    "str": [("wrong type", 5), ("unknown name", "bogus")],
    "str | None": [("wrong type", 5), ("unknown name", "bogus")],
    "tuple[str, ...]": [("wrong type", 5), ("unknown name", ("bogus",))],
    "tuple[float, ...]": [("not numbers", ("x", "y")), ("out of range", (1e12, 1e12))],
    "tuple[float, float, float]": [("wrong type", 5), ("out of range", (1e12, 1e12, 1e12))],
    "tuple[float, float]": [("wrong type", 5), ("out of range", (1e12, 1e12))],
    "CameraConfig": [("wrong type", 5), ("a dict", {"width": 320})],
    "dict": [("wrong type", 5), ("unknown key", {"bogus": 1})],
    "dict | None": [("wrong type", 5), ("unknown key", {"bogus": 1})],
    "CameraProfile | None": [
        ("wrong type", 5),
        ("unknown key", {"tone_gama": 1.3}),
        ("out of range", {"asphalt_scale": 9.0}),
        ("missing file", "nowhere.toml"),
    ],
}

#: Fields whose generated value would be valid, with cases that are not.
_FIELD_OVERRIDES: dict[tuple[str, str], list[tuple[str, object]]] = {
    ("EpisodeSpec", "driver"): [("unknown name", "bogus"), ("misspelt", "orcale")],  # a callable is also valid
    ("EpisodeSpec", "filters"): [("unknown name", ("bogus",)), ("wrong type", 5)],
}


def _field_cases() -> list:
    cases = []
    for cls in CONFIGS:
        for f in dataclasses.fields(cls):
            if not f.init or f.name.startswith("_"):
                continue
            bad = _FIELD_OVERRIDES.get((cls.__name__, f.name)) or _BY_TYPE.get(str(f.type), [])
            limit = getattr(cls, "LIMITS", {}).get(f.name)
            if limit is not None and limit.length is None:  # just outside the declared range
                low = (
                    limit.low - (1 if limit.integer else 1e-3 * max(1.0, abs(limit.low)))
                    if limit.low_inclusive
                    else limit.low
                )
                bad = [*bad, ("just below the limit", low), ("just above the limit", limit.high + (1 if limit.integer else 1e-3 * max(1.0, abs(limit.high))))]  # fmt: skip
            for why, value in bad:
                cases.append(pytest.param(cls, f.name, value, id=f"{cls.__name__}.{f.name}: {why}"))
    return cases


FIELD_CASES = _field_cases()


@pytest.mark.parametrize(("cls", "field", "value"), FIELD_CASES)
def test_every_config_field_refuses_bad_values(cls, field, value):
    _refused(lambda: cls(**{field: value}), field)


def test_every_config_field_has_cases():
    covered = {(c.values[0].__name__, c.values[1]) for c in FIELD_CASES}
    missing = [
        f"{cls.__name__}.{f.name} ({f.type})"
        for cls in CONFIGS
        for f in dataclasses.fields(cls)
        if f.init and not f.name.startswith("_") and (cls.__name__, f.name) not in covered
    ]
    assert not missing, f"fields without cases (add their type to _BY_TYPE): {missing}"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"longitudinal": "yes"}, "longitudinal"),
        ({"traffic": "no"}, "traffic"),
        ({"noise": "rain", "noise_params": {"snow": noise.SnowParams()}}, "noise_params"),
        ({"noise": "clear", "noise_params": {"rain": noise.RainParams()}}, "noise_params"),
        ({"noise": "rain", "noise_params": {"rain": noise.SnowParams()}}, "noise_params"),
        ({"widht": 320}, "widht"),
        ({"width": "wide"}, "width"),
    ],
    ids=lambda v: str(v)[:40],
)
def test_gym_make_refuses_bad_options(kwargs, name):
    _refused(lambda: gym.make("simroad/RoadCam-v0", **kwargs), name)


# -- public functions and classes ----------------------------------------------------


@pytest.fixture(scope="module")
def env():
    e = envs.RoadCamEnv(longitudinal=True, width=64, height=48)
    e.reset(seed=0)
    yield e
    e.close()


IMG = np.zeros((32, 32, 3), np.uint8)
MASK = np.zeros((32, 32), bool)

#: (public name, why, call(env, paths) -> None, parameter named in the error)
# fmt: off
FUNCTION_CASES: list[tuple[str, str, object, str]] = [
    # envs
    ("get_scenario", "wrong type", lambda e, p: envs.get_scenario(5), "scenario"),
    ("get_scenario", "unknown name", lambda e, p: envs.get_scenario("higway"), "scenario"),
    ("RoadCamEnv", "render mode", lambda e, p: envs.RoadCamEnv(render_mode="human"), "render_mode"),
    ("RoadCamEnv", "config type", lambda e, p: envs.RoadCamEnv(config=5), "config"),
    ("RoadCamEnv", "config and keywords", lambda e, p: envs.RoadCamEnv(config=RoadCamConfig(), width=64), "config"),
    ("RoadCamEnv", "unknown option", lambda e, p: envs.RoadCamEnv(bogus=1), "bogus"),
    ("RoadCamEnv", "reset options", lambda e, p: e.reset(options={"a": 1}), "options"),
    ("RoadCamEnv", "negative seed", lambda e, p: e.reset(seed=-1), "seed"),
    ("RoadCamEnv", "seed type", lambda e, p: e.reset(seed="a"), "seed"),
    ("RoadCamEnv", "string action", lambda e, p: e.step("left"), "action"),
    ("RoadCamEnv", "dict action", lambda e, p: e.step({}), "action"),
    ("RoadCamEnv", "action shape", lambda e, p: e.step([0.1, 0.2, 0.3]), "action"),
    ("RoadCamEnv", "NaN action", lambda e, p: e.step([np.nan, 0.0]), "action"),
    ("RoadCamEnv", "bev size", lambda e, p: e.render_bev(size="x"), "size"),
    ("RoadCamEnv", "bev scale", lambda e, p: e.render_bev(metres_per_px=0), "metres_per_px"),
    # noise
    ("apply_noise", "image type", lambda e, p: noise.apply_noise([1], "rain", rng=0), "image"),
    ("apply_noise", "spec type", lambda e, p: noise.apply_noise(IMG, 5, rng=0), "noise"),
    ("apply_noise", "severity range", lambda e, p: noise.apply_noise(IMG, "rain", severity=2, rng=0), "severity"),
    ("apply_noise", "no rng", lambda e, p: noise.apply_noise(IMG, "rain", rng=None), "rng"),
    (
        "apply_noise",
        "depth shape",
        lambda e, p: noise.apply_noise(IMG, "fog", rng=0, depth=np.ones((3, 3), np.float32)),
        "depth",
    ),
    ("change_mask", "wrong type", lambda e, p: radiometry.change_mask("a", IMG), "before"),
    ("change_mask", "shape mismatch", lambda e, p: radiometry.change_mask(IMG, IMG[:4]), "after"),
    ("change_mask", "threshold range", lambda e, p: radiometry.change_mask(IMG, IMG, threshold=300), "threshold"),
    ("check_noise_params", "wrong type", lambda e, p: noise.check_noise_params(5), "params"),
    ("check_noise_params", "unknown noise", lambda e, p: noise.check_noise_params({"hail": 1}), "params"),
    ("check_noise_params", "wrong Params", lambda e, p: noise.check_noise_params({"rain": noise.SnowParams()}), "rain"),
    ("flat_ground_camera", "size range", lambda e, p: noise.flat_ground_camera(-5, 3), "image"),
    ("flat_ground_camera", "wrong type", lambda e, p: noise.flat_ground_camera("x", 3), "image"),
    ("linear_to_srgb", "wrong type", lambda e, p: radiometry.linear_to_srgb("x"), "lin"),
    ("linear_to_srgb", "wrong dtype", lambda e, p: radiometry.linear_to_srgb(IMG), "lin"),
    ("srgb_to_linear", "wrong type", lambda e, p: radiometry.srgb_to_linear([1, 2]), "image"),
    ("srgb_to_linear", "wrong dtype", lambda e, p: radiometry.srgb_to_linear(IMG.astype(np.int64)), "image"),
    ("make_weather", "unknown", lambda e, p: noise.make_weather("hail"), "noise"),
    ("make_weather", "windscreen type", lambda e, p: noise.make_weather("rain", windscreen="yes"), "windscreen"),
    ("WindscreenModel", "params type", lambda e, p: noise.WindscreenModel(5), "params"),
    ("WindscreenModel", "rain rate range", lambda e, p: noise.WindscreenModel(noise.WindscreenParams(), rain_rate_mm_h=-1), "rain_rate_mm_h"),
    ("WindscreenModel", "flake density type", lambda e, p: noise.WindscreenModel(noise.WindscreenParams(), flake_density_m3="x"), "flake_density_m3"),
    ("windscreen_model", "windscreen type", lambda e, p: noise.windscreen_model({}, "yes"), "windscreen"),
    ("make_weather", "severity range", lambda e, p: noise.make_weather("rain", severity=2), "severity"),
    ("make_weather", "severity type", lambda e, p: noise.make_weather("rain", severity="x"), "severity"),
    (
        "make_weather",
        "inactive params",
        lambda e, p: noise.make_weather("rain", params={"snow": noise.SnowParams()}),
        "params",
    ),
    ("parse_noise", "wrong type", lambda e, p: noise.parse_noise(5), "noise"),
    ("parse_noise", "repeated", lambda e, p: noise.parse_noise("rain+rain"), "noise"),
    ("parse_noise", "clear and rain", lambda e, p: noise.parse_noise("clear+rain"), "noise"),
    ("parse_noise", "empty part", lambda e, p: noise.parse_noise("rain+"), "noise"),
    ("Weather", "names as a string", lambda e, p: noise.Weather("rain", severity=0.5), "names"),
    ("Weather", "unknown name", lambda e, p: noise.Weather(("hail",), severity=0.5), "names"),
    ("Weather", "severity range", lambda e, p: noise.Weather(("rain",), severity=2), "severity"),
    ("Weather", "params type", lambda e, p: noise.Weather(("rain",), severity=0.5, params=5), "params"),
    ("Limit", "wrong type", lambda e, p: noise.Limit("a", 1), "low"),
    ("Limit", "low above high", lambda e, p: noise.Limit(2, 1), "low"),
    ("NoiseContext", "dt range", lambda e, p: noise.NoiseContext(dt=0), "dt"),
    ("NoiseContext", "camera type", lambda e, p: noise.NoiseContext(camera=5), "camera"),
    ("NoiseContext", "speed range", lambda e, p: noise.NoiseContext(ego_speed=1e9), "ego_speed"),
    ("NoiseModel", "params type", lambda e, p: noise.NoiseModel(5), "params"),
    ("NoiseModel", "apply before reset", lambda e, p: noise.RainModel.from_severity(0.5).apply(IMG), "reset"),
    ("NoiseModel", "reset rng", lambda e, p: noise.RainModel.from_severity(0.5).reset(None), "rng"),
    *(
        (cls.__name__, "params type", (lambda e, p, cls=cls: cls(5)), "params")
        for cls in (noise.RainModel, noise.SnowModel, noise.ShadowModel, noise.GlareModel, noise.FogModel)
    ),
    *(
        (cls.__name__, "severity range", (lambda e, p, cls=cls: cls.from_severity(1.5)), "severity")
        for cls in (noise.RainModel, noise.SnowModel, noise.ShadowModel, noise.GlareModel, noise.FogModel)
    ),
    # control
    ("make_driver", "unknown name", lambda e, p: control.make_driver("pilot", e), "driver"),
    ("make_driver", "env type", lambda e, p: control.make_driver("oracle", 5), "env"),
    (
        "make_driver",
        "lateral-only env",
        lambda e, p: control.make_driver("oracle", envs.RoadCamEnv(width=64, height=48)),
        "env",
    ),
    ("autopilot_action", "road type", lambda e, p: control.autopilot_action(5, e.vehicle), "road"),
    ("autopilot_action", "vehicle type", lambda e, p: control.autopilot_action(e.highway_env.road, 5), "vehicle"),
    (
        "autopilot_action",
        "lookahead range",
        lambda e, p: control.autopilot_action(e.highway_env.road, e.vehicle, lookahead_s=-1),
        "lookahead_s",
    ),
    ("pure_pursuit_steering", "pose type", lambda e, p: control.pure_pursuit_steering("x", np.zeros(2), 5.0), "pose"),
    ("pure_pursuit_steering", "target type", lambda e, p: control.pure_pursuit_steering((0, 0, 0), "x", 5.0), "target"),
    (
        "pure_pursuit_steering",
        "wheelbase range",
        lambda e, p: control.pure_pursuit_steering((0, 0, 0), np.ones(2), -1),
        "wheelbase_m",
    ),
    ("MaskLaneKeeper", "camera type", lambda e, p: control.MaskLaneKeeper(5), "camera"),
    ("MaskLaneKeeper", "config type", lambda e, p: control.MaskLaneKeeper(e.camera, 5), "config"),
    ("MaskLaneKeeper", "mask type", lambda e, p: control.MaskLaneKeeper(e.camera).act("x", 5.0), "mask"),
    (
        "MaskLaneKeeper",
        "speed not finite",
        lambda e, p: control.MaskLaneKeeper(e.camera).act(np.zeros((48, 64), bool), float("nan")),
        "speed_m_s",
    ),
    ("LaneEstimator", "camera type", lambda e, p: control.LaneEstimator(5), "camera"),
    ("LaneEstimator", "config type", lambda e, p: control.LaneEstimator(e.camera, 5), "config"),
    ("CallableDriver", "not callable", lambda e, p: control.CallableDriver(5), "driver"),
    ("MaskDriver", "camera type", lambda e, p: control.MaskDriver(5, ControllerConfig()), "camera"),
    ("ControllerConfig", "scenario type", lambda e, p: ControllerConfig.for_scenario(5), "scenario"),
    (
        "ControllerConfig",
        "min above max look-ahead",
        lambda e, p: ControllerConfig(min_lookahead_m=50, max_lookahead_m=10),
        "min_lookahead_m",
    ),
    # metrics
    ("MaskScore", "pred type", lambda e, p: metrics.MaskScore().update("x", MASK), "pred"),
    ("MaskScore", "shape mismatch", lambda e, p: metrics.MaskScore().update(MASK, MASK[:3]), "shape"),
    ("SafetyScore", "dt range", lambda e, p: safety.SafetyScore(dt=-1, route_length_m=10), "dt"),
    ("SafetyScore", "route type", lambda e, p: safety.SafetyScore(dt=0.1, route_length_m="x"), "route_length_m"),
    ("confusion", "shape mismatch", lambda e, p: metrics.confusion(MASK, MASK[:3]), "shape"),
    ("confusion", "wrong type", lambda e, p: metrics.confusion("x", MASK), "pred"),
    ("error_rates", "wrong type", lambda e, p: metrics.error_rates("x", MASK), "pred"),
    ("error_rates", "float mask", lambda e, p: metrics.error_rates(MASK, np.full((32, 32), 0.5)), "gt"),
    ("footprint_corners", "vehicle type", lambda e, p: safety.footprint_corners("x"), "vehicle"),
    ("rates_from_counts", "negative count", lambda e, p: metrics.rates_from_counts(-1, 0, 0, 0), "tp"),
    ("rates_from_counts", "wrong type", lambda e, p: metrics.rates_from_counts(1, "x", 0, 0), "fp"),
    # experiments
    ("build_report", "directory does not exist", lambda e, p: experiments.build_report(p["missing"]), "dir"),
    ("collect_frames", "scenarios as a string", lambda e, p: experiments.collect_frames(scenarios="x"), "scenarios"),
    (
        "collect_frames",
        "unknown scenario",
        lambda e, p: experiments.collect_frames(scenarios=["racetrack", "higway"]),
        "scenarios",
    ),
    ("collect_frames", "no seeds", lambda e, p: experiments.collect_frames(seeds=[]), "seeds"),
    ("collect_frames", "negative seed", lambda e, p: experiments.collect_frames(seeds=[-1]), "seeds"),
    ("collect_frames", "frames range", lambda e, p: experiments.collect_frames(frames_per_seed=0), "frames_per_seed"),
    ("collect_frames", "severity range", lambda e, p: experiments.collect_frames(severity=2), "severity"),
    ("collect_frames", "noise", lambda e, p: experiments.collect_frames(noise="rian"), "noise"),
    ("collect_frames", "env options", lambda e, p: experiments.collect_frames(env_options={"widht": 3}), "widht"),
    ("export_frames", "out below a file", lambda e, p: experiments.export_frames(p["file"] + "/x"), "out"),
    ("export_frames", "count range", lambda e, p: experiments.export_frames(p["ok"], count=0), "count"),
    ("export_frames", "negative seed", lambda e, p: experiments.export_frames(p["ok"], seed=-1), "seed"),
    ("export_frames", "env_kwargs type", lambda e, p: experiments.export_frames(p["ok"], env_kwargs=5), "env_kwargs"),
    (
        "export_frames",
        "unknown env option",
        lambda e, p: experiments.export_frames(p["ok"], env_kwargs={"traffic": "no"}),
        "traffic",
    ),
    ("load_grid_file", "a directory", lambda e, p: experiments.load_grid_file(p["dir"]), "config"),
    ("load_grid_file", "missing", lambda e, p: experiments.load_grid_file(p["missing"]), "config"),
    ("load_grid_file", "malformed TOML", lambda e, p: experiments.load_grid_file(p["bad_toml"]), "config"),
    ("load_grid_file", "binary file", lambda e, p: experiments.load_grid_file(p["garbage"]), "config"),
    ("load_grid_file", "out = 5", lambda e, p: experiments.load_grid_file(p["out5"]), "out"),
    ("parse_filters", "unknown name", lambda e, p: filters.parse_filters("bogus"), "filters"),
    (
        "run_ablation",
        "backend",
        lambda e, p: experiments.run_ablation(AblationGrid(), p["ok"], backend="slurm"),
        "backend",
    ),
    (
        "run_ablation",
        "workers range",
        lambda e, p: experiments.run_ablation(AblationGrid(), p["ok"], workers=0),
        "workers",
    ),
    ("run_episode", "spec type", lambda e, p: experiments.run_episode(5), "spec"),
    (
        "run_episode",
        "video type",
        lambda e, p: experiments.run_episode(EpisodeSpec(steps=1), video=p["ok"] + "/v.avi"),
        "video",
    ),
    (
        "run_episode",
        "unknown filter to compare",
        lambda e, p: experiments.run_episode(EpisodeSpec(steps=1), video=p["ok"] + "/v.gif", video_compare="fog"),
        "video_compare",
    ),
    (
        "run_episode",
        "compare without a video",
        lambda e, p: experiments.run_episode(EpisodeSpec(steps=1), video_compare="none"),
        "video_compare",
    ),
    ("build_report", "a second sweep that is not one", lambda e, p: experiments.build_report(p["dir"], 5), "dir"),
]
# fmt: on

#: The sweep runner's and the filter names' public entry points.
SWEEPS_CASES: list[tuple[str, str, object, str]] = [
    ("run_ablation", "grid type", lambda e, p: experiments.run_ablation(5, p["ok"]), "grid"),
    ("run_cell", "spec type", lambda e, p: experiments.run_cell(5), "spec"),
    ("ResultStore", "directory type", lambda e, p: experiments.ResultStore(5), "directory"),
]
FILTER_NAME_CASES: list[tuple[str, str, object, str]] = [
    ("parse_filters", "wrong type", lambda e, p: filters.parse_filters(5), "filters"),
]

#: Public names that take no user input of their own, or are covered elsewhere.
EXEMPT = {
    "SCENARIOS": "constant",
    "SCENARIO_NAMES": "constant",
    "RoadCamConfig": "dataclass: every field walked above",
    "ScenarioSpec": "a registry record built by simroad; users pick scenarios by name (get_scenario)",
    "GAMMA": "constant",
    "DECODE_TABLE": "constant",
    "CAMERA_SHOULDER": "constant",
    "CAMERA_TONE_GAMMA": "constant",
    "as_uint8": "a dtype conversion of a frame already checked by its caller",
    "MASK_THRESHOLD": "constant",
    "MODELS": "constant",
    "NOISE_NAMES": "constant",
    "STAGES": "constant",
    "NoiseParams": "a type alias",
    "NoiseResult": "a type alias",
    "Params": "abstract base: every subclass walked above",
    "FogParams": "dataclass: walked above",
    "GlareParams": "dataclass: walked above",
    "RainParams": "dataclass: walked above",
    "ShadowParams": "dataclass: walked above",
    "SnowParams": "dataclass: walked above",
    "WindscreenParams": "dataclass: walked above",
    "WIPER_MODES": "constant",
    "DRIVER_NAMES": "constant",
    "PathEstimate": "a result record returned by LaneEstimator",
    "PENALTIES": "constant",
    "BACKENDS": "constant",
    "RECORD_KEYS": "constant",
    "AblationGrid": "dataclass: walked above",
    "EpisodeSpec": "dataclass: walked above",
    "FrameSet": "a plain container that collect_frames fills",
}


@pytest.fixture
def files(paths, write):
    return {**paths, "bad_toml": write("bad.toml", "[[[ nope"), "out5": write("out5.toml", "out = 5\n")}


@pytest.mark.parametrize(
    ("name", "call", "param"),
    [pytest.param(n, c, a, id=f"{n}: {why}") for n, why, c, a in FUNCTION_CASES]
    + [pytest.param(n, c, a, id=f"{n}: {why}") for n, why, c, a in SWEEPS_CASES]
    + [pytest.param(n, c, a, id=f"{n}: {why}") for n, why, c, a in FILTER_NAME_CASES],
)
def test_every_public_function_refuses_bad_input(name, call, param, env, files):
    _refused(lambda: call(env, files), param)


@pytest.mark.parametrize("module", ["simroad.envs", "simroad.noise", "simroad.control", "simroad.metrics", "simroad.metrics.safety", "simroad.core.radiometry", "simroad.experiments"])  # fmt: skip
def test_every_public_name_has_cases_or_an_exemption(module):
    mod = importlib.import_module(module)
    covered = {n for n, *_ in FUNCTION_CASES + SWEEPS_CASES + FILTER_NAME_CASES}
    missing = [n for n in mod.__all__ if n not in covered and n not in EXEMPT]
    assert not missing, f"{module}: public names without surface cases (add to FUNCTION_CASES or EXEMPT): {missing}"


# -- filters and detector: the checks that exist today ------------------------------

FILTER_CASES = [
    pytest.param(lambda: filters.parse_filters("bogus"), "filters", id="parse_filters unknown"),
    pytest.param(lambda: filters.check_filters(["bogus"]), "filters", id="check_filters unknown"),
    pytest.param(lambda: filters.apply_filters(IMG, ["bogus"]), "filters", id="apply_filters unknown"),
    pytest.param(lambda: filters.apply_filters("x", ["shadow"]), "image", id="apply_filters image type"),
    pytest.param(lambda: filters.guided_filter("x", IMG, radius=2, eps=0.01), "guide", id="guided_filter guide type"),
    pytest.param(lambda: filters.dark_channel("x"), "image", id="dark_channel image type"),
    pytest.param(lambda: filters.remove_shadows("x"), "image", id="remove_shadows image type"),
    pytest.param(lambda: filters.remove_rain_snow("x"), "image", id="remove_rain_snow image type"),
    pytest.param(lambda: filters.remove_highlights("x"), "image", id="remove_highlights image type"),
    pytest.param(lambda: filters.remove_shadows(IMG.astype(np.int64)), "image", id="remove_shadows dtype"),
    pytest.param(lambda: filters.box_mean(IMG.astype(np.float32), -1), "radius", id="box_mean negative radius"),
    pytest.param(lambda: filters.box_mean([[1.0]], 1), "x", id="box_mean list"),
]  # fmt: skip


def _detector_cases():
    from simroad import detector

    return [
        pytest.param(lambda: detector.hsi("x"), "image", id="hsi image type"),
        pytest.param(lambda: detector.fill_holes("x"), "mask", id="fill_holes mask type"),
        pytest.param(lambda: detector.keep_ego_component("x"), "mask", id="keep_ego_component mask type"),
        pytest.param(lambda: detector.pixel_features("x"), "image", id="pixel_features image type"),
        pytest.param(lambda: detector.RoadDetector(filters=["bogus"]).fit([IMG], [MASK]), "filters",
                     id="RoadDetector unknown filter"),
        pytest.param(lambda: detector.RoadDetector.pretrained(morphology="no"), "morphology",
                     id="pretrained string boolean"),
        pytest.param(lambda: detector.RoadDetector.pretrained().set_params(morphology="no").predict(IMG), "morphology",
                     id="RoadDetector string boolean"),
    ]  # fmt: skip


@pytest.mark.parametrize(("call", "param"), FILTER_CASES + _detector_cases())
def test_filters_and_detector_refuse_bad_input(call, param):
    _refused(call, param)


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04garbage", b"\x93NUMPY not really"], ids=["empty", "bad zip", "bad npy"])  # fmt: skip
def test_damaged_model_file_is_refused_by_name(content, tmp_path):
    from simroad.detector import RoadDetector

    path = tmp_path / "model.npz"
    path.write_bytes(content)
    _refused(lambda: RoadDetector.load(path), "model.npz")
