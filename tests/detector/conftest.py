"""Rendered racetrack frames with exact ground-truth road masks, shared by the tests."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


def render_frames(seed: int, n: int, *, size=(160, 90)) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``n`` clean frames from random poses on the racetrack of world ``seed``."""
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the environments)

    from simroad.camera import CameraConfig, CameraRenderer, PinholeCamera, WorldRaster

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # "racetrack-v0 is out of date"
        env = gym.make("racetrack-v0")
    env.reset(seed=seed)
    u = env.unwrapped
    rng = np.random.default_rng(seed)
    world = WorldRaster(u.road.network, rng)
    renderer = CameraRenderer(PinholeCamera(CameraConfig(width=size[0], height=size[1])), world, rng)
    lanes = u.road.network.lanes_list()
    images, masks = [], []
    for _ in range(n):
        lane = lanes[int(rng.integers(len(lanes)))]
        s = float(rng.uniform(0, lane.length))
        x, y = lane.position(s, float(rng.uniform(-1, 1)))
        frame = renderer.render((x, y, lane.heading_at(s) + float(rng.normal(0, 0.05))), [])
        images.append(frame.rgb)
        masks.append(frame.road_mask)
    env.close()
    return images, masks


def _frames_of(seeds, n: int, size=(160, 90)) -> tuple[list[np.ndarray], list[np.ndarray]]:
    images, masks = [], []
    for seed in seeds:
        i, m = render_frames(seed, n, size=size)
        images += i
        masks += m
    return images, masks


# Rendered (and the small detector fitted) once per test run, not once per xdist worker:
# see computed_once in tests/conftest.py.
@pytest.fixture(scope="session")
def train_frames(computed_once):
    return computed_once("train_frames", _frames_of, (1, 2, 3, 4), 3)


@pytest.fixture(scope="session")
def heldout_frames(computed_once):
    return computed_once("heldout_frames", _frames_of, (101, 102, 103, 104, 105), 3, size=(320, 180))


def _fit_small(train_frames):
    from simroad.detector import RoadDetector

    return RoadDetector(max_samples=1500).fit(*train_frames)


@pytest.fixture(scope="session")
def small_detector(computed_once, train_frames):
    return computed_once("small_detector", lambda: _fit_small(train_frames))
