"""A reset that reuses this process's last world gives the frames of a fresh build, bit
for bit (simroad.envs._world_cache, and the renderer's sky images kept by
simroad.camera._sheen)."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from simroad.camera import _sheen
from simroad.camera.sky import sky_image
from simroad.envs import RoadCamEnv, _world_cache
from simroad.experiments.rollout import autopilot_env_action

# Every scenario, each with weather that reads the world (the shadow's casters are its
# scenery) or draws from the streams after the world's.
CASES = [("racetrack", "rain+shadow"), ("highway", "fog+glare"), ("winding", "shadow"), ("town", "snow+shadow")]
STEPS = 3


@pytest.fixture(autouse=True)
def _nothing_cached():
    """Each test starts with no world and no sky image cached."""
    _world_cache.clear()
    _sheen._sky_image.cache_clear()
    _sheen._sheen_map.cache_clear()


def _digest(obs: np.ndarray, info: dict) -> str:
    h = hashlib.sha256(obs.tobytes())
    for name in ("road_mask", "depth", "material", "pose"):
        h.update(np.ascontiguousarray(info[name]).tobytes())
    for name, mask in sorted(info["noise_masks"].items()):
        h.update(name.encode() + mask.tobytes())
    h.update(repr([info[k] for k in ("speed_m_s", "lateral_offset_m", "mu", "sliding", "rewards")]).encode())
    return h.hexdigest()


def _episode(env: RoadCamEnv, seed: int) -> list[str]:
    obs, info = env.reset(seed=seed)
    out = [_digest(obs, info)]
    for _ in range(STEPS):
        obs, _, _, _, info = env.step(autopilot_env_action(env))
        out.append(_digest(obs, info))
    # The reset's streams after the world's: the next draws are those of a fresh build.
    out.append(repr((env.np_random.integers(2**62), env.renderer.sky)))
    return out


@pytest.mark.parametrize(("scenario", "noise"), CASES)
def test_a_reused_world_gives_the_frames_of_a_fresh_build(scenario, noise):
    env = RoadCamEnv(scenario=scenario, noise=noise, width=192, height=108)
    fresh = _episode(env, 5)
    assert _episode(env, 5) == fresh  # the world and scenery from the cache
    other = _episode(env, 6)  # another world in between
    assert other != fresh
    assert _episode(RoadCamEnv(scenario=scenario, noise=noise, width=192, height=108), 5) == fresh  # another env
    _world_cache.clear()
    assert _episode(env, 6) == other  # built afresh after another one was cached


def test_two_live_envs_on_one_world_keep_their_own_windows(monkeypatch):
    """Two environments on the same cached world: each frame is that of a fresh build.
    A window is reused while the view fits in it, and its origin enters the warp (a
    window assembled 40 m back, which still holds the view, changes pixels by 1): one
    env's windows must not serve the other's frames. The cache keeps no tiles here:
    every tile is rendered afresh."""
    monkeypatch.setattr(_world_cache, "TILED", 0)
    alone = _episode(RoadCamEnv(scenario="highway", noise="shadow", width=192, height=108), 3)
    a = RoadCamEnv(scenario="highway", noise="shadow", width=192, height=108)
    a.reset(seed=3)
    x, y, heading = a._pose()
    a.renderer.render((x - 40.0, y, heading))  # a window of another origin, in a's world
    b = RoadCamEnv(scenario="highway", noise="shadow", width=192, height=108)
    assert _episode(b, 3) == alone
    assert a.world is not b.world and a.world.shapes is b.world.shapes  # shared, not the same object


def test_a_world_differs_with_what_it_is_a_function_of():
    """The key tells apart worlds that differ only in the palette or texel size: no hit
    gives a world built from other inputs."""
    base = RoadCamEnv(scenario="racetrack", width=96, height=54)
    base.reset(seed=2)
    grass = RoadCamEnv(scenario="racetrack", width=96, height=54, roadside="gravel")
    grass.reset(seed=2)
    assert grass.world.palette != base.world.palette and grass.world.shapes is not base.world.shapes
    fine = RoadCamEnv(scenario="racetrack", width=96, height=54, texel_m=0.05)
    fine.reset(seed=2)
    assert fine.world.texel_m == 0.05 and fine.world.shapes is not base.world.shapes


def test_the_renderers_sky_images_are_the_functions_own_and_read_only():
    env = RoadCamEnv(scenario="town", width=96, height=54)
    env.reset(seed=4)
    sky = _sheen.renderer_sky(env.camera, env.renderer.sky)
    np.testing.assert_array_equal(sky, sky_image(env.camera, env.renderer.sky, heading=0.0))
    sheen = _sheen.renderer_sheen(env.camera, env.renderer.sky, 20)
    np.testing.assert_array_equal(sheen, _sheen.sheen_map(env.camera, env.renderer.sky, 20))
    assert not sky.flags.writeable and not sheen.flags.writeable
    assert _sheen.renderer_sky(env.camera, env.renderer.sky) is sky  # computed once
