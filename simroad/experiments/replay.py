"""Clear episodes rendered once and exposed again: the calibration's fast evaluation.

A camera profile's camera fields (:data:`~simroad.camera.profile.CAMERA_FIELDS`:
exposure, white balance, tone curve, saturation, full well) act in the sensor alone,
after the renderer; its daylight and asphalt fields change the world that is
rendered. Rendering a world (its reset: road network, textures, scenery) costs about
half a second, the sensor about a millisecond a frame. So :func:`record_worlds`
drives each world's clear episode once, as :func:`~simroad.experiments.frames.collect_frames`
drives it (the ground-truth autopilot with its seeded steering noise), and keeps what
the sensor reads at every step up to the last kept frame: the rendered frame, its
depth and face maps, the speed. :func:`replay_statistics` runs a fresh sensor with
other camera fields over those steps (the auto-exposure settling and following as in
the episode) and returns the kept frames' appearance statistics: hundreds of worlds
per evaluation instead of a dozen.

What does not follow the replayed camera: the ground's motion blur, which the
renderer applied for the recorded exposure (about a texel at highway speed), and the
sensor's random draws (its noise, white-balance error and meter bias come from a
generator of the world's seed, not the episode's: the same distribution, and the
same draws for every profile replayed).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simroad.camera.profile import CameraProfile
from simroad.camera.sensor import Sensor, exposure_travel_m
from simroad.camera.sensor_params import SensorParams
from simroad.envs import RoadCamEnv
from simroad.errors import InvalidParameterError
from simroad.experiments.pool import run_in_workers
from simroad.experiments.rollout import drive_autopilot
from simroad.metrics.appearance import STATISTICS, frame_appearance

__all__ = ["WorldRecording", "record_world", "record_worlds", "replay_frames", "replay_statistics"]

#: Steering noise of the recorded drives (collect_frames' default).
_STEER_NOISE = 0.08


@dataclass
class WorldRecording:
    """One world's clear episode as the sensor reads it.

    Attributes
    ----------
    scenario : str
    seed : int
    illuminant_k : float
        The world's daylight colour temperature (the white balance's scene).
    steps : list of tuple
        ``(rgb, depth, face_id, speed_m_s, starts)`` of every step from the reset on:
        the rendered frame (uint8), its depth (float32) and face map (int32), the
        ego's speed and whether an episode starts at it (a reset: the sensor starts
        afresh).
    kept : dict
        ``{step index: road mask}`` of the frames whose statistics count.
    """

    scenario: str
    seed: int
    illuminant_k: float
    steps: list[tuple[np.ndarray, np.ndarray, np.ndarray, float, bool]] = field(default_factory=list)
    kept: dict[int, np.ndarray] = field(default_factory=dict)


def _grab(
    env: RoadCamEnv, params: SensorParams, ev: float, starts: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, bool]:
    """The current step's rendered frame, re-rendered as the episode rendered it
    (the ground blurred for the exposure ``ev`` the sensor had before this frame)."""
    speed = float(env.vehicle.speed)
    fr = env.render_scene(motion_m=exposure_travel_m(params, speed, ev))
    return fr.rgb, fr.depth, fr.face_id, speed, starts


def record_world(item: tuple[str, int, CameraProfile, int, int, Mapping[str, Any]]) -> WorldRecording:
    """Drive one world's clear episode and record it (:class:`WorldRecording`).

    ``item`` is ``(scenario, seed, profile, frames, every, env_options)``: the frames at
    policy steps ``every``, ``2 * every``, ... ``frames * every`` are kept, as
    :func:`~simroad.experiments.frames.collect_frames` with ``frames + 1`` frames per
    seed keeps them after its first. ``profile`` renders the world (its daylight and
    asphalt) and exposes the recorded episode (the ground's motion blur follows its
    exposures). A top-level function of one picklable argument: worker processes run it.
    """
    scenario, seed, profile, frames, every, options = item
    env = RoadCamEnv(scenario=scenario, noise="clear", **{**options, "camera_profile": profile})
    try:
        params = env.config.sensor_params
        if params is None:
            raise InvalidParameterError(
                "env_options: camera_effects=False leaves no sensor to calibrate; drop camera_effects."
            )
        env.reset(seed=int(seed))
        rec = WorldRecording(scenario, int(seed), float(env.renderer.sky.illuminant_k))  # type: ignore[union-attr]
        rec.steps.append(_grab(env, params, 0.0, True))  # the reset's frame, at the nominal exposure
        rng = np.random.default_rng([int(seed), 7])
        for i in range(frames):
            for _ in range(every):
                sensor = env.sensor  # present after a reset with camera effects on
                ev = sensor.ev  # type: ignore[union-attr]
                _, info = drive_autopilot(env, 1, reset_seed=int(seed) + 10_000 + i, rng=rng, steer_noise=_STEER_NOISE)
                starts = env.sensor is not sensor  # the episode ended and a new one began
                rec.steps.append(_grab(env, params, 0.0 if starts else ev, starts))
            rec.kept[len(rec.steps) - 1] = info["road_mask"]
        return rec
    finally:
        env.close()


def record_worlds(
    profile: CameraProfile,
    *,
    scenarios: Sequence[str],
    seeds: Iterable[int],
    frames: int,
    every: int,
    env_options: Mapping[str, Any] | None = None,
    workers: int = 1,
) -> list[WorldRecording]:
    """:func:`record_world` of every scenario and seed, in ``workers`` processes
    (1: in this one); in scenario, then seed order."""
    items = [(sc, int(s), profile, int(frames), int(every), dict(env_options or {})) for sc in scenarios for s in seeds]
    if workers <= 1 or len(items) < 2:
        return [record_world(it) for it in items]
    done = {(r.scenario, r.seed): r for r in run_in_workers(items, workers, record_world)}
    return [done[(it[0], it[1])] for it in items]


def _cameras(recordings: Sequence[WorldRecording], profile: CameraProfile, env_options) -> dict[str, tuple[Any, Any]]:
    """Each recorded scenario's camera and sensor parameters with ``profile``'s camera."""
    out: dict[str, tuple[Any, Any]] = {}
    for scenario in dict.fromkeys(rec.scenario for rec in recordings):
        env = RoadCamEnv(scenario=scenario, noise="clear", **{**(env_options or {}), "camera_profile": profile})
        out[scenario] = (env.camera, env.config.sensor_params)
        env.close()
    return out


def _expose(rec: WorldRecording, camera: Any, params: Any) -> list[tuple[int, np.ndarray]]:
    """``(step, frame)`` of the kept steps of one recorded world, exposed afresh."""
    sensor = Sensor(params, camera)
    kept = []
    for k, (rgb, depth, face_id, speed, starts) in enumerate(rec.steps):
        if starts:
            sensor.reset(np.random.default_rng([rec.seed, k, 99]), illuminant_k=rec.illuminant_k)
        out = sensor.apply(rgb, speed_m_s=speed, depth=depth, face_id=face_id)
        if k in rec.kept:
            kept.append((k, out))
    return kept


def _per_world(fn, recordings: Sequence[WorldRecording], threads: int) -> Iterator[Any]:
    """``fn(rec)`` of every recording, in order; ``threads`` at once (the sensor's
    kernels and OpenCV release the interpreter's lock)."""
    if threads <= 1:
        yield from map(fn, recordings)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        yield from pool.map(fn, recordings)


def replay_frames(
    recordings: Sequence[WorldRecording],
    profile: CameraProfile,
    *,
    env_options: Mapping[str, Any] | None = None,
    threads: int = 1,
) -> Iterator[tuple[WorldRecording, int, np.ndarray]]:
    """Expose the recorded worlds again with ``profile``'s camera fields (its other
    fields are the recording's): ``(recording, step, frame)`` of every kept step, in
    order. Each world's sensor starts afresh at its reset (a generator of the world's
    seed and the step), settles on the first frame and follows the recorded ones.
    ``threads`` worlds are exposed at once; the frames are the same."""
    cameras = _cameras(recordings, profile, env_options)
    for rec, kept in zip(recordings, _per_world(lambda r: _expose(r, *cameras[r.scenario]), recordings, threads)):
        for k, out in kept:
            yield rec, k, out


def replay_statistics(
    recordings: Sequence[WorldRecording],
    profile: CameraProfile,
    *,
    env_options: Mapping[str, Any] | None = None,
    threads: int = 1,
) -> dict[str, np.ndarray]:
    """The appearance statistics of :func:`replay_frames`' frames: ``{statistic: float
    array (n_frames,)}`` (NaN where a statistic has no value; frames with too little
    road left out), as :func:`~simroad.experiments.calibrate.profile_statistics` gives
    them for rendered episodes; ``threads`` as for :func:`replay_frames`."""
    cameras = _cameras(recordings, profile, env_options)

    def world(rec: WorldRecording) -> list[dict[str, float]]:
        stats = (frame_appearance(out, rec.kept[k]) for k, out in _expose(rec, *cameras[rec.scenario]))
        return [row for row in stats if row is not None]

    rows = [row for rows in _per_world(world, recordings, threads) for row in rows]
    return {s: np.array([r[s] for r in rows], float) for s in STATISTICS}
