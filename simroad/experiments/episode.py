"""One closed-loop episode: camera -> (detector) -> controller -> highway-env, scored
on the mask and on safety.

The record it returns (``simroad episode --json``) has these keys:

========================  ======================================================
scenario, noise           the world and the weather (noise canonical, e.g. ``rain+glare``)
severity                  weather severity in [0, 1]
filters                   ``none`` or the detector's filters joined by ``+``
driver                    ``detector``, ``oracle`` or ``custom``
seed, steps               episode seed; steps actually driven
fnr, fpr                  pooled over all evaluated pixels of the episode (KITTI style)
fnr_frame_mean, ...       ``fpr_frame_mean``: means of the per-frame rates
iou, f1                   pooled intersection-over-union and F1 of the road class
collided ... driving_score  safety metrics, see :mod:`simroad.metrics.safety`
min_ttc_s                 ``null`` when no vehicle ahead was ever closing in
detect_ms_median          median milliseconds of mask prediction per step
step_ms_median            median milliseconds of one whole policy step (render,
                          weather, perception, control, highway-env)
wall_s                    wall-clock seconds of the episode
========================  ======================================================

Mask metrics count the pixels that see the ground within the camera's range
(``camera.ground_valid``: sky and the horizon band are excluded; other vehicles
count as non-road).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simroad._validation import check_choice, check_in_range, check_int_in_range
from simroad.control.drivers import DRIVER_NAMES, SCENARIO_CONTROL, make_driver
from simroad.envs import RoadCamEnv
from simroad.filters import FILTER_NAMES, format_filters, parse_filters  # re-exported here for old imports
from simroad.metrics.safety import SafetyScore

__all__ = ["FILTER_NAMES", "RECORD_KEYS", "EpisodeSpec", "format_filters", "parse_filters", "run_episode"]

RECORD_KEYS = (
    "scenario", "noise", "severity", "filters", "driver", "seed", "steps",
    "fnr", "fpr", "fnr_frame_mean", "fpr_frame_mean", "iou", "f1",
    "collided", "offroad_steps", "offroad_fraction", "lane_departures",
    "lateral_rmse_m", "lateral_max_m", "heading_rmse_deg", "distance_m",
    "route_completion", "min_ttc_s", "driving_score",
    "detect_ms_median", "step_ms_median", "wall_s",
)  # fmt: skip


@dataclass(frozen=True)
class EpisodeSpec:
    """What one episode runs. ``route_m`` defaults to :func:`default_route_m`: one
    racetrack lap or 1 km, shortened to what the step budget can cover."""

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

    def __post_init__(self) -> None:
        check_int_in_range("steps", self.steps, 1, 1_000_000)
        check_int_in_range("seed", self.seed, 0, 2**31 - 1)
        object.__setattr__(self, "filters", parse_filters(self.filters))
        if isinstance(self.driver, str):
            check_choice("driver", self.driver, DRIVER_NAMES)
        if self.route_m is not None:
            check_in_range("route_m", self.route_m, 1.0, 1e6, unit="m")


def _mask_scorer():
    from simroad.metrics.mask import MaskScore

    return MaskScore()


def run_episode(
    spec: EpisodeSpec,
    *,
    driver: Callable | None = None,
    detector=None,
    video: str | None = None,
) -> dict[str, Any]:
    """Drive one episode and return its record (keys :data:`RECORD_KEYS`).

    Parameters
    ----------
    spec : EpisodeSpec
    driver : callable, optional
        A custom ``obs -> action`` (or ``obs -> (action, mask)``) replacing
        ``spec.driver``.
    detector : RoadDetector, optional
        The detector of the ``detector`` driver (default: the shipped model with
        ``spec.filters``).
    video : path, optional
        Write an mp4 or GIF of the episode (see :mod:`simroad.experiments.video`).
    """
    t_start = time.perf_counter()
    env = RoadCamEnv(scenario=spec.scenario, noise=spec.noise, severity=spec.severity, longitudinal=True,
                     traffic=spec.traffic, duration_s=1e3 if spec.steps * 0.2 > 1e3 else max(0.2, spec.steps * 0.2),
                     **spec.env_options)  # fmt: skip
    pilot = make_driver(driver if driver is not None else spec.driver, env, filters=spec.filters, detector=detector)
    obs, info = env.reset(seed=spec.seed)
    pilot.reset()
    route_m = spec.route_m if spec.route_m is not None else default_route_m(env, spec.steps)
    safety = SafetyScore(dt=env.dt, route_length_m=route_m)
    masks = _mask_scorer()
    valid = env.camera.ground_valid
    recorder = None
    if video is not None:
        from simroad.experiments.video import EpisodeVideo

        recorder = EpisodeVideo(video, env)
    detect_ms, step_ms = [], []
    steps = 0
    for _ in range(spec.steps):
        t0 = time.perf_counter()
        action = pilot(obs, info)
        t1 = time.perf_counter()
        pred = getattr(pilot, "last_mask", None)
        if pred is not None:
            masks.update(pred, info["road_mask"], valid=valid)
        if recorder is not None:
            recorder.add(obs, info, pred)
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
        "seed": spec.seed,
        "steps": steps,
    }
    record.update(_mask_record(masks))
    record.update(safety.result())
    if not math.isfinite(record["min_ttc_s"]):
        record["min_ttc_s"] = None
    record["detect_ms_median"] = float(np.median(detect_ms)) if detect_ms else 0.0
    record["step_ms_median"] = float(np.median(step_ms)) if step_ms else 0.0
    record["wall_s"] = time.perf_counter() - t_start
    return {k: record[k] for k in RECORD_KEYS}


def scenario_route_m(env) -> float:
    """The scenario's route from the ego's start: one lap of the ego's lane ring on the
    racetrack (following highway-env's lane successors), 1 km elsewhere."""
    net = env.highway_env.road.network
    start = env.vehicle.lane_index
    index, total = start, 0.0
    for _ in range(200):
        total += float(net.get_lane(index).length)
        nxt = net.next_lane(index, position=env.vehicle.position, np_random=np.random.default_rng(0))
        if nxt is None or nxt[:2] == index[:2]:
            return 1000.0  # not a loop
        index = nxt
        if index == start:
            return total
    return 1000.0


def default_route_m(env, steps: int) -> float:
    """The route an episode is scored against (route completion): the scenario route
    (:func:`scenario_route_m`), shortened to what 80 % of the scenario's cruise speed
    covers in ``steps`` policy steps when the step budget cannot cover it."""
    cruise = SCENARIO_CONTROL[env.config.scenario]["target_speed_m_s"]
    return min(scenario_route_m(env), 0.8 * cruise * steps * env.dt)


def _mask_record(masks) -> dict[str, float]:
    r = masks.summary()
    return {
        "fnr": float(r["fnr"]), "fpr": float(r["fpr"]),
        "fnr_frame_mean": float(r["mean_fnr"]), "fpr_frame_mean": float(r["mean_fpr"]),
        "iou": float(r["iou"]), "f1": float(r["f1"]),
    }  # fmt: skip
