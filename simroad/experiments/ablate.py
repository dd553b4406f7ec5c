"""Run an ablation sweep: every grid cell one episode, in parallel, resumable.

Results go to ``DIR/results.jsonl``, one record per finished episode (the
``simroad episode --json`` keys plus ``error``), appended by the parent process
only, each line with one ``write`` on an ``O_APPEND`` descriptor and ``fsync``. A
sweep killed at any moment (``kill -9`` included) leaves at most one torn last
line; the next run drops it, skips every cell already recorded, and runs the rest,
so the file ends with exactly one valid row per cell. ``DIR/grid.json`` pins the
grid: a directory holding a different grid is refused unless ``fresh=True``.

Backends: ``local`` (a process pool, the default) and ``ray`` (``pip install
simroad[ray]``; ``ray_address="HOST:PORT"`` joins a running cluster, where every
node needs simroad at the driver's version). Both call the same :func:`run_cell`,
and every episode depends only on its spec and seed, so the numbers are the same
whatever the backend or the number of workers. On Ray a cell whose node dies is
rerun elsewhere (:mod:`simroad.experiments._ray_backend`); rows are still written by
this process only.
"""

from __future__ import annotations

import json
import math
import os
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict
from pathlib import Path
from typing import Any

from simroad._validation import SimroadError, check_choice, check_int_in_range
from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, format_filters, run_episode
from simroad.experiments.grid import AblationGrid, cell_key

__all__ = ["BACKENDS", "ResultStore", "run_ablation", "run_cell"]

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
    try:
        record = episode_fn(spec)
        record["error"] = None
    except Exception as exc:
        record = dict.fromkeys(RECORD_KEYS, math.nan)
        record.update(
            scenario=spec.scenario, noise=spec.noise, severity=spec.severity if spec.noise != "clear" else 0.0,
            filters=format_filters(spec.filters), driver=spec.driver, seed=spec.seed, steps=0,
        )  # fmt: skip
        record["error"] = f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}"
    return record


class ResultStore:
    """Append-only JSON-lines results with crash repair.

    Parameters
    ----------
    directory : path
        Holds ``results.jsonl`` and ``grid.json``.
    """

    def __init__(self, directory: str | os.PathLike) -> None:
        self.dir = Path(directory)
        self.path = self.dir / "results.jsonl"
        self.grid_path = self.dir / "grid.json"

    def open(self, grid: AblationGrid, *, fresh: bool = False) -> dict[str, dict]:
        """Prepare the directory for ``grid`` and return the records already done."""
        from simroad.experiments.export import ensure_writable_dir

        ensure_writable_dir("out", self.dir)
        meta = {"fingerprint": grid.fingerprint(), "grid": asdict(grid)}
        if self.grid_path.exists() and not fresh:
            old = json.loads(self.grid_path.read_text())
            if old.get("fingerprint") != meta["fingerprint"]:
                raise SimroadError(
                    f"out: {str(self.dir)!r} holds results of a different grid ({old.get('grid')}). "
                    f"Choose another --out, or pass --fresh to delete them and start anew."
                )
        if fresh and self.path.exists():
            self.path.unlink()
        _atomic_write(self.grid_path, json.dumps(meta, indent=1))
        return self.repair()

    def repair(self) -> dict[str, dict]:
        """Drop torn or duplicate lines (rewriting the file atomically if needed)."""
        done: dict[str, dict] = {}
        dirty = False
        if self.path.exists():
            for line in self.path.read_text().splitlines():
                try:
                    rec = json.loads(line)
                    key = cell_key(rec)
                except (ValueError, KeyError, TypeError):
                    dirty = True
                    continue
                if key in done:
                    dirty = True
                    continue
                done[key] = rec
            if dirty or (not self.path.read_bytes().endswith(b"\n") and done):
                _atomic_write(self.path, "".join(json.dumps(r) + "\n" for r in done.values()))
        return done

    def append(self, record: dict) -> None:
        """Append one record durably with a single write."""
        line = (json.dumps(record) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)

    def records(self) -> list[dict]:
        """The valid records, one per cell (repairing the file first if needed)."""
        return list(self.repair().values())


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


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
    with ProcessPoolExecutor(max_workers=workers, initializer=_one_thread) as pool:
        pending = {pool.submit(cell_fn, s) for s in specs[: 2 * workers]}
        queue = list(specs[2 * workers :])
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                yield fut.result()
                if queue:
                    pending.add(pool.submit(cell_fn, queue.pop(0)))


def _ray(specs: list[EpisodeSpec], workers: int, address: str | None, cell_fn: Callable) -> Iterator[dict]:
    """The Ray backend (:mod:`simroad.experiments._ray_backend`): one task per cell, retried on node death."""
    from simroad.experiments._ray_backend import run_on_ray

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
    top-level function.
    """
    check_choice("backend", backend, BACKENDS)
    workers = check_int_in_range("workers", workers if workers is not None else (os.cpu_count() or 1), 1, 4096)
    specs = grid.specs()
    if not specs:
        raise SimroadError("grid: it has no cells; give at least one scenario, noise, filter set and seed.")
    store = ResultStore(out)
    done = store.open(grid, fresh=fresh)
    todo = [s for s in specs if cell_key(s) not in done]
    from tqdm import tqdm

    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), disable=not progress, unit="episode", desc="ablate")
    runner = _local(todo, workers, cell_fn) if backend == "local" else _ray(todo, workers, ray_address, cell_fn)
    for record in runner:
        store.append(record)
        bar.update(1)
        if record.get("error"):
            bar.write(f"episode {cell_key(record)} failed: {record['error'].splitlines()[0]}")
    bar.close()
    return store.records()
