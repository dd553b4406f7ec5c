"""Ground truth agrees with highway-env's own lane geometry.

For every sampled pixel that sees the ground (its material is a ground material:
scenery and vehicles in front of the road hide it), ``road_mask`` must equal "the
ground point that ``camera.image_to_ground`` gives lies on some lane", decided with
highway-env's ``lane.local_coordinates`` and ``lane.width_at``; and no pixel that sees
an object or the sky is road.
"""

from __future__ import annotations

import numpy as np
import pytest

from simroad.camera.codes import IS_GROUND
from simroad.envs import RoadCamEnv
from simroad.experiments.rollout import autopilot_env_action


def _on_some_lane(network, xy: np.ndarray) -> np.ndarray:
    lanes = network.lanes_list()
    out = np.zeros(len(xy), dtype=bool)
    for lane in lanes:
        for k in np.nonzero(~out)[0]:
            s, lat = lane.local_coordinates(xy[k])
            if 0.0 <= s <= lane.length and abs(lat) <= lane.width_at(s) / 2.0:
                out[k] = True
    return out


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["racetrack", "highway", "winding", "town"])
def test_road_mask_agrees_with_lane_geometry(scenario):
    agree, total = 0, 0
    for seed in (0, 1, 2):
        env = RoadCamEnv(scenario=scenario, traffic=True)
        _obs, info = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for step in range(3):
            if step:
                for _ in range(4):
                    _obs, _, _term, _trunc, info = env.step(autopilot_env_action(env))
            assert not (info["road_mask"] & ~IS_GROUND[info["material"]]).any()  # objects hide the road
            valid = env.camera.ground_valid & IS_GROUND[info["material"]]
            v, u = np.nonzero(valid)
            pick = rng.choice(len(u), size=400, replace=False)
            xy = env.camera.image_to_ground(np.column_stack([u[pick], v[pick]]).astype(float))
            keep = ~np.isnan(xy[:, 0])
            truth = _on_some_lane(env.highway_env.road.network, xy[keep])
            mask = info["road_mask"][v[pick][keep], u[pick][keep]]
            agree += int((truth == mask).sum())
            total += int(keep.sum())
        env.close()
    assert total >= 3400
    assert agree / total >= 0.995, f"{scenario}: {agree}/{total} agree"
