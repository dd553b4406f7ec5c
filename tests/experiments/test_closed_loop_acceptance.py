"""Closed-loop acceptance, clear weather, with traffic: a full racetrack lap and five
winding roads of 1 km, driven by the oracle and by the shipped detector."""

from __future__ import annotations

import pytest

from simroad.experiments.episode import EpisodeSpec, run_episode

pytestmark = pytest.mark.slow  # closed-loop episodes of 7-15 s each

ROADS = [("racetrack", 0, None)] + [("winding", seed, 1000.0) for seed in range(1, 6)]
# World 3's verges are grey gravel, the colour of its asphalt under any exposure: the
# per-pixel colour classifier takes the left verge for road (FPR 0.3) and the car leaves
# the road after 200 m. Real gravel shoulders do the same to a colour classifier.
_GRAVEL = pytest.mark.xfail(strict=True, reason="winding world 3: gravel verges the colour of the road")
DETECTOR_ROADS = [pytest.param(*road, marks=_GRAVEL) if road == ("winding", 3, 1000.0) else road for road in ROADS]


@pytest.mark.parametrize("scenario, seed, route_m", ROADS)
def test_oracle_drives_cleanly(scenario, seed, route_m):
    rec = run_episode(EpisodeSpec(scenario=scenario, seed=seed, steps=600, driver="oracle", route_m=route_m))
    assert rec["route_completion"] == 1.0  # a full lap / the whole kilometre
    assert rec["offroad_steps"] == 0 and not rec["collided"]
    assert rec["lateral_rmse_m"] <= 0.3


@pytest.mark.parametrize("scenario, seed, route_m", DETECTOR_ROADS)
def test_detector_driver_stays_on_the_road(scenario, seed, route_m):
    rec = run_episode(EpisodeSpec(scenario=scenario, seed=seed, steps=600, driver="detector", route_m=route_m))
    assert rec["offroad_fraction"] <= 0.01
    assert rec["route_completion"] >= 0.95
    assert not rec["collided"]


# Racetrack world 100 with this look's traffic: in the tight left bend after 100 steps the
# road fills the view, neither edge is in it, the path estimate degenerates to a constant
# offset and the car drifts 1.7 m out (2 steps off the road). A weakness of the lane
# keeper's path reading, not of perception: the oracle reads the ground truth.
_TIGHT_BEND = pytest.mark.xfail(strict=True, reason="racetrack world 100: no edge in view in a tight bend")


@pytest.mark.parametrize(
    "scenario, seed",
    [("highway", 100), ("highway", 101), ("highway", 102), pytest.param("racetrack", 100, marks=_TIGHT_BEND)],
)
def test_oracle_in_traffic_neither_crashes_nor_leaves_the_road(scenario, seed):
    # Regressions: a car's side read as the road edge sent the oracle across the
    # highway and off it (seed 100); a car ahead in the lane, beside which the road
    # run went on, was not braked for on the racetrack (seed 100).
    rec = run_episode(EpisodeSpec(scenario=scenario, seed=seed, steps=150, driver="oracle"))
    assert rec["offroad_steps"] == 0 and not rec["collided"]
    assert rec["lateral_rmse_m"] <= 0.3
