"""Sweep throughput: episodes per minute with 1 vs 2 local workers, and the Ray
backend's overhead against the local pool on the same 2 cores.

Every run starts as a user's first sweep in a process would: the in-process run (one
worker) with no world cached (:mod:`simroad.envs._world_cache`), so that it does not
reuse the worlds an earlier run of this benchmark built."""

from __future__ import annotations

import importlib.util
import shutil
import tempfile
import time

import numpy as np


def main() -> None:
    from simroad.envs import _world_cache
    from simroad.experiments.ablate import run_ablation
    from simroad.experiments.grid import AblationGrid

    grid = AblationGrid(
        scenarios=("racetrack", "winding"),
        noises=("clear", "rain"),
        severities=(0.6,),
        filters=("none", "all"),
        seeds=2,
        steps=40,
        oracle=False,
    )
    n = len(grid.specs())
    runs = {"local, 1 worker": dict(workers=1), "local, 2 workers": dict(workers=2)}
    if importlib.util.find_spec("ray") is not None:
        runs["ray, 2 workers (incl. start-up)"] = dict(workers=2, backend="ray")
    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(2):  # alternate the candidates, twice
        for name, kw in runs.items():
            out = tempfile.mkdtemp(prefix="simroad-bench-")
            _world_cache.clear()
            t0 = time.perf_counter()
            run_ablation(grid, out, progress=False, **kw)
            times[name].append(time.perf_counter() - t0)
            shutil.rmtree(out, ignore_errors=True)
    print(f"\n## sweep throughput ({n} episodes of {grid.steps} steps, 320x180; medians of 2 alternating runs)")
    print(f"{'backend':<36} {'wall s':>8} {'episodes/min':>13}")
    med = {k: float(np.median(v)) for k, v in times.items()}
    for name, t in med.items():
        print(f"{name:<36} {t:>8.1f} {60.0 * n / t:>13.1f}")
    speedup = med["local, 1 worker"] / med["local, 2 workers"]
    print(f"2 workers vs 1: {speedup:.2f}x episodes/min (target >= 1.7x)")
    ray_key = "ray, 2 workers (incl. start-up)"
    if ray_key in med:
        print(
            f"Ray vs local pool, 2 workers: {med[ray_key] / med['local, 2 workers']:.2f}x the wall time ({med[ray_key] - med['local, 2 workers']:+.1f} s)"
        )


if __name__ == "__main__":
    main()
