"""Side-by-side timing: medians and ratios measured in one interleaved run.

The machine is shared and noisy, so every candidate of a comparison is timed in
round-robin order (a, b, c, a, b, c, ...) and the ratio of medians is reported;
absolute milliseconds are only indicative.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")


def one_core() -> None:
    """Pin OpenCV to one thread, so "per frame on one core" means that."""
    import cv2

    cv2.setNumThreads(1)


def interleaved(
    candidates: dict[str, Callable[[], object]],
    *,
    repeats: int = 50,
    warmup: int = 3,
    clock: Callable[[], float] = time.perf_counter,
) -> dict[str, np.ndarray]:
    """Time each candidate ``repeats`` times in round-robin order; seconds per call.

    ``clock`` is wall time by default; ``time.thread_time`` counts only the CPU time of
    this thread, which other processes on a busy shared machine do not inflate.
    """
    for fn in candidates.values():
        for _ in range(warmup):
            fn()
    times: dict[str, list[float]] = {k: [] for k in candidates}
    for _ in range(repeats):
        for name, fn in candidates.items():
            t0 = clock()
            fn()
            times[name].append(clock() - t0)
    return {k: np.asarray(v) for k, v in times.items()}


def table(
    title: str, times: dict[str, np.ndarray], *, baseline: str | None = None, target_ms: dict[str, float] | None = None
) -> str:
    """Format medians (ms) and ratios to ``baseline`` as a text table."""
    target_ms = target_ms or {}
    lines = [f"\n## {title}", f"{'stage':<48} {'median ms':>10} {'p90 ms':>9} {'ratio':>9}  target"]
    base = float(np.median(times[baseline])) if baseline else None
    for name, t in times.items():
        med = float(np.median(t)) * 1e3
        p90 = float(np.percentile(t, 90)) * 1e3
        ratio = f"{(base * 1e3) / med:8.2f}x" if base else ""
        if baseline and name == baseline:
            ratio = "  (base)"
        tgt = target_ms.get(name)
        mark = "" if tgt is None else (f"<= {tgt:g} ms " + ("ok" if med <= tgt else "MISSED"))
        lines.append(f"{name:<48} {med:>10.3f} {p90:>9.3f} {ratio:>9}  {mark}")
    if baseline:
        lines.append(f"(ratio = median of '{baseline}' / median of the row; >1 means the row is faster)")
    return "\n".join(lines)


def bare_racetrack_step() -> Callable[[], None]:
    """One bare highway-env ``racetrack-v0`` step (Kinematics observation, no
    rendering), resetting when the car crashes or leaves the road: the baseline
    every simroad cost is compared with."""
    import gymnasium as gym
    import highway_env  # noqa: F401

    bare = gym.make("racetrack-v0", config={"observation": {"type": "Kinematics"}, "other_vehicles": 1}).unwrapped
    bare.reset(seed=0)
    action = np.zeros(1, dtype=np.float32)

    def step() -> None:
        bare.step(action)
        if bare.vehicle.crashed or not bare.vehicle.on_road:
            bare.reset(seed=0)

    return step
