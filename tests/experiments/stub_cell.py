"""A stub episode for fast runner tests: deterministic, slow enough to be killed."""

from __future__ import annotations

import time

from simroad.experiments.episode import RECORD_KEYS, format_filters


def stub_cell(spec):
    time.sleep(0.05)
    if spec.seed == 13 and spec.driver == "oracle":
        raise_in = True
    else:
        raise_in = False
    record = dict.fromkeys(RECORD_KEYS, 0.0)
    record.update(scenario=spec.scenario, noise=spec.noise, severity=spec.severity, filters=format_filters(spec.filters),
                  driver=spec.driver, seed=spec.seed, steps=spec.steps)  # fmt: skip
    record["fnr"] = (spec.seed * 7919 % 101) / 1000.0
    record["error"] = "RuntimeError: boom" if raise_in else None
    return record
