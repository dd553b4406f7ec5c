"""The search of ``simroad calibrate``: the camera's fields and the world's, in blocks.

The camera fields (:data:`~simroad.camera.profile.CAMERA_FIELDS`) act after the
renderer, so a profile that changes only them is scored on recorded renders
(:mod:`simroad.experiments.replay`: a millisecond a frame); the daylight and
asphalt fields change the world and cost a render of every world per profile.

The search: Nelder-Mead over the camera's fields on the first render; then, when
world fields are fitted, Nelder-Mead over them in which each profile tried is
rendered and scored with the camera that suits it best (a short Nelder-Mead over the
camera's fields from the best so far, on that render): the world's and the camera's
fields trade off (a paler asphalt or a brighter exposure both lighten the road), and
searching them one block at a time would stall in such a valley. Last, the camera's
fields once more on the best render. Every search runs on the fields mapped to
[0, 1] (:mod:`simroad.experiments.profile_space`), by scipy's Nelder-Mead.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.optimize import minimize
from tqdm import tqdm

from simroad.camera.profile import CAMERA_FIELDS
from simroad.experiments.profile_space import from_unit, simplex, to_unit, unit_coordinates

__all__ = ["BlockSearch"]

#: The first simplex's step (unit coordinates): wide for a search from the start,
#: narrow for one from the best camera so far.
_WIDE, _NARROW = 0.2, 0.05
#: Profiles each world profile's camera search may score, per camera field (and 2
#: more). Measured (benchmarks/calibration_check.py): with 10 per field the camera
#: made up for any asphalt (a flat valley: the world's search stayed at the start),
#: with 5 the fit landed nearer the truth.
_INNER_PER_FIELD = 5


def _key(x: np.ndarray) -> bytes:
    """A point of the unit box as a memo key (clipped into it, as the profile is)."""
    return np.round(np.clip(x, 0.0, 1.0), 9).tobytes()


class BlockSearch:
    """The search of :func:`~simroad.experiments.calibrate.calibrate_profile` (the
    module docstring has the plan).

    ``objective(values)`` scores a profile's statistics (0 is a match),
    ``render(profile)`` renders and records the worlds, ``replay(recordings, profile)``
    returns the statistics of the recordings exposed with ``profile``'s camera.
    :meth:`run` leaves the best profile (``profile``), its objective and values
    (``best``), the start's (``first``) and the counts (``renders``, ``replays``)."""

    def __init__(self, objective, render, replay, names, start, max_renders, max_replays, progress):
        self.objective, self.render, self.replay, self.profile = objective, render, replay, start
        self.camera = unit_coordinates(tuple(n for n in names if n in CAMERA_FIELDS))
        self.world = unit_coordinates(tuple(n for n in names if n not in CAMERA_FIELDS))
        self.max_renders, self.max_replays = max_renders, max_replays
        self.renders = self.replays = 0
        self.bar = tqdm(total=max_renders, desc="calibrate", unit="render", disable=not progress)
        self.recordings: Any = None
        self.best: tuple[float, dict[str, np.ndarray]] = (math.inf, {})
        self.first: tuple[float, dict[str, np.ndarray]] = (math.inf, {})

    def _score(self, recordings, profile) -> float:
        values = self.replay(recordings, profile)
        self.replays += 1
        scored = (self.objective(values), values)
        if scored[0] < self.best[0]:
            self.best, self.profile, self.recordings = scored, profile, recordings
        self.bar.set_postfix(best=f"{self.best[0]:.3f}", replays=self.replays)
        return scored[0]

    def _record(self, profile):
        self.renders += 1
        self.bar.update(1)
        return self.render(profile)

    def run(self) -> None:
        self.recordings = self._record(self.profile)
        self._score(self.recordings, self.profile)
        self.first = self.best
        if self.camera:
            share = self.max_replays // 3 if self.world else self.max_replays
            self._camera(self.recordings, self.profile, self.best[0], share - self.replays, _WIDE)
        if self.world and self.renders < self.max_renders:
            self._world()
            if self.camera:
                self._camera(self.recordings, self.profile, self.best[0], self.max_replays - self.replays, _NARROW)

    def _camera(self, recordings, base, base_objective: float, budget: int, step: float) -> float:
        """Nelder-Mead over the camera fields from ``base`` (scored ``base_objective``
        on ``recordings``), ``budget`` replays at most; the lowest objective seen."""
        memo: dict[bytes, float] = {}

        def objective(x: np.ndarray) -> float:
            key = _key(x)
            if key not in memo:
                if self.replays >= self.max_replays:
                    return math.inf
                memo[key] = self._score(recordings, from_unit(x, base, self.camera))
            return memo[key]

        x0 = to_unit(base, self.camera)
        memo[_key(x0)] = base_objective
        self._nelder_mead(objective, x0, budget + 1, step)
        return min(memo.values())

    def _world(self) -> None:
        """Nelder-Mead over the daylight and asphalt fields: a render per profile, scored
        with the camera that suits it (a short camera search from the best so far)."""
        base, memo = self.profile, {}
        renders_left = self.max_renders - self.renders
        inner = _INNER_PER_FIELD * len(self.camera) + 2 if self.camera else 0

        def objective(x: np.ndarray) -> float:
            key = _key(x)
            if key not in memo:
                if self.renders >= self.max_renders:
                    return math.inf
                profile = from_unit(x, base, self.world)
                recordings = self._record(profile)
                value = self._score(recordings, profile)
                if inner:
                    budget = min(inner, (self.max_replays - self.replays) // max(1, renders_left))
                    value = self._camera(recordings, profile, value, budget, _NARROW)
                memo[key] = value
            return memo[key]

        x0 = to_unit(base, self.world)
        memo[_key(x0)] = self.best[0]  # the base: rendered and searched already
        self._nelder_mead(objective, x0, renders_left + 1, _WIDE)

    @staticmethod
    def _nelder_mead(objective, x0: np.ndarray, budget: int, step: float) -> None:
        if budget <= 1:
            return
        minimize(
            objective,
            x0,
            method="Nelder-Mead",
            bounds=[(0.0, 1.0)] * x0.size,
            options={"maxfev": budget, "initial_simplex": simplex(x0, step), "xatol": 0.004, "fatol": 0.002},
        )
