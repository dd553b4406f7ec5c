"""Colour alone does not separate road from non-road, as in photographs.

Measured on whole clean frames of held-out worlds with OpenCV HSV (a pixel is grey
when S < 0.15 and 0.15 < V < 0.85): road photographs (CamVid, KITTI, ACDC) have
38-55 % of road and 13-37 % of non-road pixels grey. simroad 0.1's worlds had
~90 % of road and 13-19 % of non-road pixels grey; this release measures 66-67 % of
road and 24-43 % of non-road pixels (70 % in the town). The targets: at most 80 % of road
pixels grey, at least 15 % of non-road pixels (25 % in the town, whose sidewalks,
kerbs and facades are grey).
"""

from __future__ import annotations

import numpy as np
import pytest

from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments.rollout import autopilot_env_action
from simroad.metrics.colour import GreyCounts, grey_counts

pytestmark = pytest.mark.slow

HELD_OUT = tuple(range(200, 206))  # worlds no training or figure uses
NON_ROAD_MIN = {"town": 0.25}


def _world_fractions(scenario: str, seed: int, frames: int = 5, every: int = 4) -> tuple[float, float]:
    env = RoadCamEnv(scenario=scenario)
    obs, info = env.reset(seed=seed)
    total = GreyCounts()
    for k in range(frames):
        total = total + grey_counts(obs, info["road_mask"])
        if k < frames - 1:
            for _ in range(every):
                obs, _, term, trunc, info = env.step(autopilot_env_action(env))
                if term or trunc:
                    break
    env.close()
    return total.road_fraction, total.other_fraction


@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
def test_grey_pixels_are_not_only_road(scenario: str) -> None:
    fr = np.array([_world_fractions(scenario, s) for s in HELD_OUT])
    road, other = fr.mean(axis=0)
    assert road <= 0.80, f"{scenario}: {road:.1%} of road pixels are grey (photographs: 38-55 %)"
    need = NON_ROAD_MIN.get(scenario, 0.15)
    assert other >= need, f"{scenario}: only {other:.1%} of non-road pixels are grey (need >= {need:.0%})"
