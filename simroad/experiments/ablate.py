"""Run an ablation sweep: every grid cell one episode, in parallel, resumable.

Results go to ``DIR/results.jsonl``, one record per finished episode (the
``simroad episode --json`` keys plus ``error``), appended by the parent process
only, each line with one ``write`` on an ``O_APPEND`` descriptor and ``fsync``. A
sweep killed at any moment (``kill -9`` included) leaves at most one torn last
line; the next run moves it to ``results.rejected.jsonl`` (saying so), skips every
cell already recorded, and runs the rest, so the file ends with exactly one valid
row per cell (:mod:`simroad.experiments.results` defines a valid row).
``DIR/grid.json`` pins the grid: a directory holding a different grid is refused
unless ``fresh=True``. ``DIR/sweep.lock`` keeps a second sweep out of the directory
while one runs (:mod:`simroad.experiments.outlock`). Ctrl-C ends the sweep and its
workers (:mod:`simroad.experiments.pool`); a second Ctrl-C kills them at once.

Backends: ``local`` (worker processes, the default) and ``ray`` (``pip install
simroad[ray]``; ``ray_address="HOST:PORT"`` joins a running cluster, where every
node needs simroad at the driver's version). Both call the same :func:`run_cell`,
and every episode depends only on its spec and seed, so the numbers are the same
whatever the backend or the number of workers. On Ray a cell whose node dies is
rerun elsewhere (:mod:`simroad.experiments._ray_backend`); rows are still written by
this process only.

Before the first episode every detector of the cells to run predicts one frame of
their world (:func:`preflight_detectors`): a detector that cannot be built, raises or
returns no mask stops the sweep at once, by name, instead of failing cell by cell.
"""

from __future__ import annotations

import math
import os
import traceback
from collections.abc import Callable, Generator, Iterator
from typing import Any

from simroad.core.validation import check_choice, check_int_in_range, ensure_writable_dir
from simroad.detector.registry import load_detector, predict_checked, start_episode
from simroad.errors import DetectorFailedError, InvalidParameterError
from simroad.experiments._ray_backend import run_on_ray
from simroad.experiments.episode import (
    RECORD_KEYS,
    EpisodeSpec,
    episode_env,
    options_record,
    profile_record,
    run_episode,
)
from simroad.experiments.grid import AblationGrid, cell_key
from simroad.experiments.outlock import OutputLock
from simroad.experiments.pool import Interrupts, default_workers, run_in_workers
from simroad.experiments.results import ResultStore  # re-exported here for old imports
from simroad.filters.pipeline import format_filters

__all__ = ["BACKENDS", "preflight_detectors", "run_ablation", "run_cell"]

BACKENDS = ("local", "ray")


def run_cell(spec: EpisodeSpec, *, episode_fn: Callable[[EpisodeSpec], dict[str, Any]] = run_episode) -> dict[str, Any]:
    """Run one episode; a failure becomes a record with ``error`` set, never a crash.

    Parameters
    ----------
    spec : EpisodeSpec
        The cell.
    episode_fn : callable, optional
        ``spec -> record`` (default :func:`run_episode`; tests pass a stub).

    Returns
    -------
    dict
        The episode's record plus ``error``: None, or the exception's type, message
        and a short traceback, with the cell's identity keys kept and every metric
        NaN.
    """
    if not isinstance(spec, EpisodeSpec):
        raise InvalidParameterError(f"spec: expected an EpisodeSpec, got {type(spec).__name__} {spec!r}.")
    try:
        record = episode_fn(spec)
        record["error"] = None
    except Exception as exc:
        record = dict.fromkeys(RECORD_KEYS, math.nan)
        record.update(
            scenario=spec.scenario, noise=spec.noise, severity=spec.severity if spec.noise != "clear" else 0.0,
            filters=format_filters(spec.filters), driver=spec.driver, seed=spec.seed, steps=0, step_budget=spec.steps,
            detector="", detector_version="", detector_spec=spec.detector if spec.driver == "detector" else "",
            friction=spec.env_options.get("friction", True),
            camera_profile=profile_record(spec.env_options.get("camera_profile")),
            detector_options=options_record(spec.detector_options) if spec.driver == "detector" else {},
            env_options=options_record({k: v for k, v in spec.env_options.items() if k != "camera_profile"}),
        )  # fmt: skip
        record["error"] = f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}"
    return record


def preflight_detectors(specs: list[EpisodeSpec]) -> None:
    """Build each detector the detector cells of ``specs`` name (with its options, and
    the filters of its first cell) and predict the first frame of that cell's world.

    Raises :class:`~simroad.errors.InvalidParameterError` for a detector that cannot
    be built and :class:`~simroad.errors.DetectorFailedError` for one that raises or
    returns no mask, naming the detector and the frame. One reset per distinct world
    configuration; the detectors stay cached for this process's episodes."""
    tried: set[tuple] = set()
    frames: dict[tuple, tuple[Any, Any]] = {}
    for spec in specs:
        if spec.driver != "detector":
            continue
        key = (spec.detector, repr(sorted(spec.detector_options.items())))  # once per detector: filters are ours
        if key in tried:
            continue
        tried.add(key)
        world = (spec.scenario, spec.noise, spec.severity, spec.seed, spec.traffic, repr(spec.env_options))
        if world not in frames:
            env = episode_env(spec)
            obs, _ = env.reset(seed=spec.seed)
            frames[world] = (obs, env.camera)
            env.close()
        obs, camera = frames[world]
        detector = load_detector(spec.detector, spec.detector_options, filters=spec.filters)
        try:
            predict_checked(start_episode(detector, camera), obs, detector)
        except DetectorFailedError as exc:
            raise DetectorFailedError(
                f"{exc} It failed on the first frame of {spec.scenario}, {spec.noise}, seed {spec.seed}, before "
                "the sweep started: no episode was run."
            ) from exc


def _one_thread() -> None:
    """Pool initializer: a sweep parallelises across episodes, so each episode
    process uses one OpenCV thread (no oversubscription of the cores)."""
    import cv2

    cv2.setNumThreads(1)


def _local(specs: list[EpisodeSpec], workers: int, cell_fn: Callable) -> Iterator[dict]:
    if workers == 1:
        import cv2

        before = cv2.getNumThreads()
        _one_thread()
        try:
            for spec in specs:
                yield cell_fn(spec)
        finally:
            cv2.setNumThreads(before)
        return
    with Interrupts() as interrupts:
        yield from run_in_workers(specs, workers, cell_fn, initializer=_one_thread, interrupts=interrupts)


def _ray(specs: list[EpisodeSpec], workers: int, address: str | None, cell_fn: Callable) -> Iterator[dict]:
    """The Ray backend (:mod:`simroad.experiments._ray_backend`): one task per cell, retried on node death."""

    return run_on_ray(specs, workers=workers, address=address, cell_fn=cell_fn)


def run_ablation(
    grid: AblationGrid,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    backend: str = "local",
    ray_address: str | None = None,
    fresh: bool = False,
    progress: bool = True,
    cell_fn: Callable[[EpisodeSpec], dict] = run_cell,
) -> list[dict]:
    """Run every cell of ``grid`` not yet in ``out/results.jsonl``; return all records.

    ``cell_fn`` runs one cell (default :func:`run_cell`); it must be a picklable
    top-level function of an importable module (with ``workers > 1`` the workers
    start from a fork server and import it; not a notebook's function). The output directory is locked for the whole run
    (:class:`~simroad.experiments.outlock.OutputLock`): a second sweep on it raises
    :class:`~simroad.errors.OutputInUseError` naming the holder's PID. With the default
    ``cell_fn``, :func:`preflight_detectors` runs before the first episode.
    """

    if not isinstance(grid, AblationGrid):
        raise InvalidParameterError(
            f"grid: expected an AblationGrid, got {type(grid).__name__} {grid!r}. "
            "Build one with AblationGrid(scenarios=..., noises=...) or load_grid_file(path)."
        )
    check_choice("backend", backend, BACKENDS)
    workers = check_int_in_range("workers", workers if workers is not None else default_workers(), 1, 4096)
    specs = grid.specs()
    if not specs:
        raise InvalidParameterError("grid: it has no cells; give at least one scenario, noise, filter set and seed.")
    ensure_writable_dir("out", out)
    with OutputLock(out):  # before grid.json is read or written
        store = ResultStore(out)
        done = store.open(grid, fresh=fresh)
        todo = [s for s in specs if cell_key(s) not in done]
        if cell_fn is run_cell:  # real episodes: try every detector on one frame first
            preflight_detectors(todo)
        from tqdm import tqdm

        bar = tqdm(
            total=len(specs), initial=len(specs) - len(todo), disable=not progress, unit="episode", desc="ablate"
        )
        runner = _local(todo, workers, cell_fn) if backend == "local" else _ray(todo, workers, ray_address, cell_fn)
        try:
            for record in runner:
                store.append(record)
                bar.update(1)
                if record.get("error"):
                    bar.write(f"episode {cell_key(record)} failed: {record['error'].splitlines()[0]}")
        finally:
            if isinstance(runner, Generator):  # end the workers if the loop stopped early
                runner.close()
            bar.close()
        return store.records()
