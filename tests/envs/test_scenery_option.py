"""RoadCamConfig.scenery: validated, 0 = a bare world, and it shifts no other random stream."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.camera.codes import GROUND_MATERIALS, SKY, VEHICLE
from simroad.camera.mesh import Mesh
from simroad.camera.scenery import Scenery
from simroad.envs import RoadCamEnv
from simroad.errors import SimroadError


@pytest.mark.parametrize("value", [-0.1, 5.5, float("nan"), "dense"])
def test_env_scenery_option_is_validated(value):
    with pytest.raises(SimroadError, match="scenery"):
        RoadCamEnv(scenery=value)


def test_env_scenery_zero_leaves_the_world_bare_and_the_other_streams_alone():
    a, b = RoadCamEnv(width=64, height=48, scenery=0.0), RoadCamEnv(width=64, height=48)
    oa, info_a = a.reset(seed=3)
    ob, info_b = b.reset(seed=3)
    assert a.world.scenery is None and isinstance(b.world.scenery, Scenery)
    # Traffic, palette and weather do not shift with the scenery.
    assert a._pose() == b._pose()
    assert a.world.palette == b.world.palette
    assert len(b.world.objects(-200, -200, 200, 200)) > 0
    assert isinstance(a.world.objects(-200, -200, 200, 200), Mesh)
    # The bare frame sees ground, cars and sky only; the scenery is in view in the other.
    bare = {*GROUND_MATERIALS, VEHICLE, SKY}
    assert set(np.unique(info_a["material"])) <= bare
    assert not set(np.unique(info_b["material"])) <= bare and not np.array_equal(oa, ob)
