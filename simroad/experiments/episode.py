"""Run one closed-loop episode and score it on the mask and on safety.

The loop: camera -> (detector) -> controller -> highway-env.

The record it returns (``simroad episode --json``) has these keys:

========================  ======================================================
scenario, noise           the world and the weather (noise canonical, e.g. ``rain+glare``)
severity                  weather severity in [0, 1]
filters                   ``none`` or the detector's filters joined by ``+``
driver                    ``detector``, ``oracle`` or ``custom``
detector                  what drove: the detector's ``name`` (``paper`` for the
                          shipped one, else its own or its spec), ``""`` for the
                          oracle and custom drivers
detector_version          its ``version`` (``""`` when it has none)
detector_spec             the spec it was built from (``EpisodeSpec.detector``;
                          ``""`` for the oracle and custom drivers)
seed, steps               episode seed; steps actually driven
step_budget               the steps it was given (``EpisodeSpec.steps``): part of
                          the cell's identity, so sweeps run for different budgets
                          stay apart
fnr, fpr                  pooled over the ground pixels of the episode (KITTI style:
                          the episode's summed counts; see below)
fnr_frame_mean, ...       ``fpr_frame_mean``: means over frames of each frame's own
                          ground-pixel rate (a different number from the pooled one)
fnr_image, fpr_image      pooled over every pixel of every frame (sky and all above
                          the horizon are non-road): a mask that calls the sky road
                          raises ``fpr_image`` but not ``fpr``
iou, f1                   pooled intersection-over-union and F1 of the road class
collided ... driving_score  safety metrics, see :mod:`simroad.metrics.safety`
min_ttc_s                 ``null`` when no vehicle ahead was ever closing in
min_stopping_margin_m     gap to the vehicle ahead minus the stopping distance at
                          the braking the tyres allow (``null`` when no vehicle
                          was ever ahead; see :mod:`simroad.metrics.safety`)
slide_steps               policy steps in which the ego's tyres slid
mean_speed_m_s            distance over time driven, m/s
start_speed_m_s           the ego's speed after the reset, m/s: the scenario's
                          cruise speed, lower where the grip does not allow it
                          (:mod:`simroad.envs.tyres`)
friction                  whether tyre–road friction limited the dynamics
                          (RoadCam's ``friction`` option)
camera_profile            the camera the frames came from: the fields of the
                          episode's :class:`~simroad.camera.profile.CameraProfile`
                          (``CameraProfile.as_dict()``; simroad's default profile
                          when none was given)
detect_ms_median          median milliseconds of one driver call per step
                          (perception and control: the detector's mask
                          prediction plus the lane keeper, or a custom driver)
step_ms_median            median milliseconds of one whole policy step (render,
                          weather, perception, control, highway-env)
wall_s                    wall-clock seconds of the episode
========================  ======================================================

Mask metrics count the pixels that see the ground within the camera's range
(``camera.ground_valid``: sky and the horizon band are excluded; other vehicles
count as non-road), except ``fnr_image`` and ``fpr_image``, which count the whole
frame (the ground truth is non-road wherever the camera does not see the ground).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simroad.camera.profile import resolve_profile
from simroad.control.drivers import DRIVER_NAMES, make_driver
from simroad.core.validation import (
    check_bool,
    check_choice,
    check_in_range,
    check_int_in_range,
    check_output_file,
)
from simroad.detector.registry import check_detector, describe, load_detector
from simroad.envs import RoadCamConfig, RoadCamEnv, get_scenario
from simroad.envs.routes import lap_length_m
from simroad.errors import InvalidParameterError, SimroadError
from simroad.experiments.video import EpisodeVideo
from simroad.filters import format_filters, parse_filters  # re-exported here for old imports
from simroad.metrics.mask import MaskScore
from simroad.metrics.safety import SafetyScore

__all__ = ["RECORD_KEYS", "EpisodeSpec", "episode_env", "options_record", "profile_record", "run_episode"]

RECORD_KEYS = (
    "scenario", "noise", "severity", "filters", "driver", "detector", "detector_version",
    "detector_spec", "detector_options", "seed", "steps", "step_budget",
    "fnr", "fpr", "fnr_frame_mean", "fpr_frame_mean", "fnr_image", "fpr_image", "iou", "f1",
    "collided", "offroad_steps", "offroad_fraction", "lane_departures",
    "lateral_rmse_m", "lateral_max_m", "heading_rmse_deg", "distance_m",
    "route_completion", "min_ttc_s", "min_stopping_margin_m", "slide_steps", "mean_speed_m_s",
    "start_speed_m_s", "friction",
    "camera_profile", "env_options", "driving_score",
    "detect_ms_median", "step_ms_median", "wall_s",
)  # fmt: skip


@dataclass(frozen=True)
class EpisodeSpec:
    """What one episode runs. ``route_m`` defaults to :func:`default_route_m`: the
    scenario's route (:class:`~simroad.envs.ScenarioSpec`: one racetrack lap, else
    ``route_m``), shortened to what the step budget can cover. The episode's time
    limit is ``steps`` policy periods of the scenario (at least one, at most 1000 s).
    ``detector`` is a detector spec (:func:`simroad.detector.registry.load_detector`:
    ``paper``, a registered name, ``module:attr`` or ``file.py:attr``) built with
    ``detector_options``; the ``filters`` run in front of it."""

    scenario: str = "racetrack"
    noise: str = "clear"
    severity: float = 0.5
    filters: tuple[str, ...] = ()
    driver: str = "detector"
    seed: int = 0
    steps: int = 300
    traffic: bool = True
    route_m: float | None = None
    env_options: dict = field(default_factory=dict)
    detector: str = "paper"
    detector_options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        # Stored as plain int/float: numpy scalars or 3.0 would reach gymnasium's seeding,
        # range() and json.dumps of the record.
        object.__setattr__(self, "steps", check_int_in_range("steps", self.steps, 1, 1_000_000))
        object.__setattr__(self, "seed", check_int_in_range("seed", self.seed, 0, 2**31 - 1))
        object.__setattr__(self, "severity", check_in_range("severity", self.severity, 0.0, 1.0))
        if not isinstance(self.filters, (str, list, tuple)):
            raise InvalidParameterError(
                f"filters: expected 'none', 'all', names joined by '+' or a tuple of names, got "
                f"{type(self.filters).__name__} {self.filters!r}."
            )
        object.__setattr__(self, "filters", parse_filters(self.filters))
        if isinstance(self.driver, str) or not callable(self.driver):
            check_choice("driver", self.driver, DRIVER_NAMES)
        if self.route_m is not None:
            object.__setattr__(self, "route_m", check_in_range("route_m", self.route_m, 1.0, 1e6, unit="m"))
        if not isinstance(self.detector, str) or not self.detector.strip():
            raise InvalidParameterError(
                f"detector: expected a detector spec ('paper', a registered name, 'module:attr' or "
                f"'path/to/file.py:attr'), got {self.detector!r}."
            )
        object.__setattr__(self, "detector_options", check_detector(self.detector, self.detector_options)[1])
        self._check_env()

    def _check_env(self) -> None:
        """Validate the environment's options now, not when the episode starts."""
        check_bool("traffic", self.traffic)
        if not isinstance(self.env_options, Mapping):
            raise InvalidParameterError(
                f"env_options: expected a dict of RoadCam options such as {{'width': 640}}, "
                f"got {type(self.env_options).__name__}."
            )
        clash = sorted(set(self.env_options) & set(_SPEC_ENV_KEYS))
        if clash:
            raise InvalidParameterError(
                f"env_options: {', '.join(map(repr, clash))} set by the spec itself; pass "
                f"{', '.join(f'{k}=...' for k in clash if k in _SPEC_FIELDS) or 'nothing'} to EpisodeSpec "
                "instead (longitudinal and duration_s follow from the driver and steps)."
            )
        own = {"scenario": self.scenario, "noise": self.noise, "severity": self.severity, "traffic": self.traffic}
        RoadCamConfig.from_kwargs(**own)
        try:
            RoadCamConfig.from_kwargs(**own, **self.env_options)
        except SimroadError as exc:
            raise InvalidParameterError(f"env_options: {exc}") from None


#: RoadCam options the spec sets itself (so not allowed in ``env_options``).
_SPEC_ENV_KEYS = ("scenario", "noise", "severity", "traffic", "longitudinal", "duration_s")
_SPEC_FIELDS = ("scenario", "noise", "severity", "traffic")

#: Longest episode time limit in simulated s (``EpisodeSpec.steps`` beyond it are cut).
_MAX_DURATION_S = 1e3
#: A step budget is expected to cover this fraction of cruise speed x time (route cap).
_ROUTE_SPEED_FRACTION = 0.8


def episode_env(spec: EpisodeSpec) -> RoadCamEnv:
    """The environment :func:`run_episode` drives ``spec`` in (not yet reset)."""
    period = get_scenario(spec.scenario).policy_period_s
    duration_s = _MAX_DURATION_S if spec.steps * period > _MAX_DURATION_S else max(period, spec.steps * period)
    return RoadCamEnv(scenario=spec.scenario, noise=spec.noise, severity=spec.severity, longitudinal=True,
                      traffic=spec.traffic, duration_s=duration_s, **spec.env_options)  # fmt: skip


def run_episode(
    spec: EpisodeSpec,
    *,
    driver: Callable | None = None,
    detector=None,
    video: str | None = None,
    video_compare: str | Sequence[str] | None = None,
) -> dict[str, Any]:
    """Drive one episode and return its record (keys :data:`RECORD_KEYS`).

    Parameters
    ----------
    spec : EpisodeSpec
    driver : callable, optional
        A custom ``obs -> action`` (or ``obs -> (action, mask)``) replacing
        ``spec.driver``.
    detector : object with ``predict(image) -> bool mask``, optional
        The detector of the ``detector`` driver, as it is (``spec.filters`` are not
        put in front of it); default: ``spec.detector`` built with
        ``spec.detector_options`` and ``spec.filters`` (once per process).
    video : path, optional
        Write an mp4 or GIF of the episode (see :mod:`simroad.experiments.video`).
    video_compare : str or sequence of str, optional
        A filter set (``none``, ``all``, names): the video shows, left of the driving
        detector's view, what ``spec.detector`` with these filters finds on the same
        frames. It does not drive and is not scored. Needs ``video`` and the detector
        driver.
    """
    if not isinstance(spec, EpisodeSpec):
        raise InvalidParameterError(f"spec: expected an EpisodeSpec(...), got {type(spec).__name__}.")
    if video is not None:
        check_output_file("video", video, suffixes=(".mp4", ".gif"))
    if video_compare is not None:
        if video is None or driver is not None or spec.driver != "detector":
            raise InvalidParameterError(
                "video_compare: it shows a second filter set of the driving detector in the video; "
                "give video= and use the detector driver, or leave video_compare out."
            )
        try:
            video_compare = parse_filters(video_compare)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"video_compare: {str(exc).removeprefix('filters: ')}") from None
    t_start = time.perf_counter()
    env = episode_env(spec)
    kind = driver if driver is not None else spec.driver
    if kind == "detector" and detector is None:
        detector = load_detector(spec.detector, spec.detector_options, filters=spec.filters)
    pilot = make_driver(kind, env, filters=spec.filters, detector=detector)
    beside = None  # the same detector with other filters, seen in the video only
    if video_compare is not None:
        other = load_detector(spec.detector, spec.detector_options, filters=video_compare)
        beside = make_driver("detector", env, detector=other)
    obs, info = env.reset(seed=spec.seed)
    start_speed = float(env.vehicle.speed)
    pilot.reset()
    if beside is not None:
        beside.reset()
    route_m = spec.route_m if spec.route_m is not None else default_route_m(env, spec.steps)
    safety = SafetyScore(dt=env.dt, route_length_m=route_m)
    masks, whole = MaskScore(), MaskScore()
    valid = env.camera.ground_valid
    recorder = None
    if video is not None:
        labels = ("", "") if video_compare is None else (
            f"filters {format_filters(video_compare)}", f"filters {format_filters(spec.filters)}"
        )  # fmt: skip
        recorder = EpisodeVideo(video, env, caption=video_caption(spec, driver is not None), labels=labels)
    detect_ms, step_ms = [], []
    steps = 0
    for _ in range(spec.steps):
        t0 = time.perf_counter()
        action = pilot(obs, info)
        t1 = time.perf_counter()
        pred = getattr(pilot, "last_mask", None)
        if pred is not None:
            masks.update(pred, info["road_mask"], valid=valid)
            whole.update(pred, info["road_mask"])
        if recorder is not None:
            if beside is not None:
                beside(obs, info)
            recorder.add(obs, info, pred, beside=None if beside is None else beside.last_mask)
        obs, _, terminated, truncated, info = env.step(action)
        step_ms.append((time.perf_counter() - t0) * 1e3)
        detect_ms.append((t1 - t0) * 1e3)
        steps += 1
        safety.update(env.highway_env.road, env.vehicle, info)
        if terminated or truncated or safety.progress_m >= route_m:
            break
    if recorder is not None:
        recorder.close()
    env.close()
    record: dict[str, Any] = {
        "scenario": spec.scenario,
        "noise": env.config.noise,
        "severity": spec.severity if env.config.noise != "clear" else 0.0,
        "filters": format_filters(spec.filters),
        "driver": spec.driver if driver is None else "custom",
        **_detector_record(pilot),
        "detector_spec": spec.detector if kind == "detector" and driver is None else "",
        "detector_options": options_record(spec.detector_options) if kind == "detector" and driver is None else {},
        "seed": spec.seed,
        "steps": steps,
        "step_budget": spec.steps,
    }
    record.update(_mask_record(masks, whole))
    record.update(safety.result())
    for key in ("min_ttc_s", "min_stopping_margin_m"):
        if not math.isfinite(record[key]):
            record[key] = None
    record["start_speed_m_s"] = start_speed
    record["friction"] = env.config.friction
    record["camera_profile"] = profile_record(env.config.camera_profile)
    record["env_options"] = options_record({k: v for k, v in spec.env_options.items() if k != "camera_profile"})
    record["detect_ms_median"] = float(np.median(detect_ms)) if detect_ms else 0.0
    record["step_ms_median"] = float(np.median(step_ms)) if step_ms else 0.0
    record["wall_s"] = time.perf_counter() - t_start
    return {k: record[k] for k in RECORD_KEYS}


def profile_record(profile: Any) -> dict[str, Any]:
    """The ``camera_profile`` of a record: the fields of ``profile`` (a CameraProfile,
    a dict, a TOML path, or None for simroad's default)."""
    return resolve_profile(profile).as_dict()


def video_caption(spec: EpisodeSpec, custom: bool = False) -> str:
    """The caption of an episode's video: world, weather, what drove."""
    weather = spec.noise if spec.noise == "clear" else f"{spec.noise} {spec.severity:g}"
    if custom:
        who = "custom driver"
    elif spec.driver == "oracle":
        who = "oracle (ground truth)"
    else:
        who = f"{spec.detector}, filters {format_filters(spec.filters)}"
    return f"{spec.scenario} world {spec.seed}, {weather}: {who}"


def options_record(options: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` as JSON values for a record (``detector_options``, ``env_options``):
    dataclasses as their fields, tuples as lists, NumPy scalars and arrays as numbers
    and lists, paths and anything else as text."""

    def value(v: Any) -> Any:
        if dataclasses.is_dataclass(v) and not isinstance(v, type):
            return value(dataclasses.asdict(v))
        if isinstance(v, Mapping):
            return {str(k): value(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [value(x) for x in v]
        if isinstance(v, (np.generic, np.ndarray)):
            return v.tolist()
        if v is None or isinstance(v, (bool, int, float, str)):
            return v
        return str(v)

    return {str(k): value(v) for k, v in options.items()}


def _detector_record(pilot: Any) -> dict[str, str]:
    det = getattr(pilot, "detector", None)
    if det is None:
        return {"detector": "", "detector_version": ""}
    d = describe(det)
    return {"detector": d["name"], "detector_version": d["version"]}


def scenario_route_m(env: RoadCamEnv) -> float:
    """The scenario's route from the ego's start (:class:`~simroad.envs.ScenarioSpec`):
    on a lap scenario (the racetrack) one lap of the ego's lane ring, following
    highway-env's lane successors; else (or if the ring does not close) the spec's
    ``route_m`` (1 km)."""
    scenario = get_scenario(env.config.scenario)
    if scenario.route_is_lap:
        lap = lap_length_m(env.highway_env.road.network, env.vehicle.lane_index, position=env.vehicle.position)
        if lap is not None:
            return lap
    return scenario.route_m


def default_route_m(env, steps: int) -> float:
    """The route an episode is scored against (route completion): the scenario route
    (:func:`scenario_route_m`), shortened to what ``_ROUTE_SPEED_FRACTION`` (80 %) of
    the scenario's cruise speed covers in ``steps`` policy steps when the step budget
    cannot cover it."""
    cruise = get_scenario(env.config.scenario).cruise_speed_m_s
    return min(scenario_route_m(env), _ROUTE_SPEED_FRACTION * cruise * steps * env.dt)


def _mask_record(ground: MaskScore, whole: MaskScore) -> dict[str, float]:
    """The record's mask keys: ``ground`` scored on the ground pixels, ``whole`` on
    every pixel of the same frames."""
    r, w = ground.summary(), whole.pooled()
    return {
        "fnr": float(r["fnr"]), "fpr": float(r["fpr"]),
        "fnr_frame_mean": float(r["mean_fnr"]), "fpr_frame_mean": float(r["mean_fpr"]),
        "fnr_image": float(w["fnr"]), "fpr_image": float(w["fpr"]),
        "iou": float(r["iou"]), "f1": float(r["f1"]),
    }  # fmt: skip
