"""A stub episode for fast runner tests: deterministic, raising for one chosen cell so
the runner's error branch (:func:`run_cell`) runs, and as slow as :data:`DELAY_S` says
(the kill test raises it so that the sweep is still running when it is killed)."""

from __future__ import annotations

import os
import time

from simroad.experiments.ablate import run_cell
from simroad.experiments.episode import RECORD_KEYS
from simroad.filters.pipeline import format_filters

#: Seconds each stub episode sleeps, from the environment variable ``SIMROAD_STUB_DELAY_S``
#: (sweep workers start from a fork server and import this module afresh: set the variable
#: before the first sweep of the process, not this attribute).
DELAY_S = float(os.environ.get("SIMROAD_STUB_DELAY_S", "0.005"))
#: The cell whose episode raises: the oracle of seed 13.
FAILING_SEED, FAILING_DRIVER = 13, "oracle"


def stub_episode(spec):
    """A fake ``run_episode``: a record whose FNR depends on the seed only."""
    time.sleep(DELAY_S)
    if spec.seed == FAILING_SEED and spec.driver == FAILING_DRIVER:
        raise RuntimeError("boom")
    record = dict.fromkeys(RECORD_KEYS, 0.0)
    record["camera_profile"] = record["detector_options"] = record["env_options"] = {}
    record.update(scenario=spec.scenario, noise=spec.noise, severity=spec.severity, filters=format_filters(spec.filters),
                  driver=spec.driver, seed=spec.seed, steps=spec.steps, step_budget=spec.steps)  # fmt: skip
    detector = spec.detector if spec.driver == "detector" else ""
    record.update(detector=detector, detector_version="", detector_spec=detector)
    record["fnr"] = (spec.seed * 7919 % 101) / 1000.0
    return record


def stub_cell(spec):
    """The real :func:`run_cell` around the stub episode (picklable, top level)."""
    return run_cell(spec, episode_fn=stub_episode)


def contender(out: str, grid, start, conn) -> None:
    """One of two concurrent sweeps (a process of its own, see test_sweep_faults):
    report (outcome, message) through ``conn``."""
    import traceback

    from simroad import SimroadError
    from simroad.errors import OutputInUseError
    from simroad.experiments.ablate import run_ablation

    global DELAY_S
    try:
        DELAY_S = 0.01  # 12 cells: ~0.12 s of work, so the two usually overlap
        start.wait(timeout=30)
        run_ablation(grid, out, workers=1, progress=False, cell_fn=stub_cell)
        result = ("done", "")
    except OutputInUseError as exc:
        result = ("locked", str(exc))
    except SimroadError as exc:
        result = ("refused", str(exc))
    except BaseException:
        result = ("crash", traceback.format_exc())
    conn.send(result)
    os._exit(0)


def fake_record(**kw):
    """A valid results row of a paper-detector episode (rain 0.7, racetrack, seed 0, 5
    steps, every metric 0), with ``kw`` changed."""
    r = dict.fromkeys(RECORD_KEYS, 0.0)
    r["camera_profile"] = r["detector_options"] = r["env_options"] = {}
    r.update(scenario="racetrack", noise="rain", severity=0.7, filters="none", driver="detector",
             seed=0, steps=5, step_budget=5)  # fmt: skip
    r.update(detector="paper", detector_version="", detector_spec="paper")
    r.update(collided=False, offroad_steps=0, lane_departures=0, min_ttc_s=None, error=None)
    r.update(kw)
    return r
