"""A sample scene for the weather models: one rendered racetrack frame with its geometry.

The frame the README gallery, the noise benchmark and the weather tests share: the
ego on the first straight of highway-env's racetrack, heading world +x (towards the
glare's default sun), with a red car ahead. :func:`sample_context` gives the
:class:`~simroad.noise.NoiseContext` that goes with it.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, cast

import numpy as np

from simroad.camera import CameraConfig, CameraRenderer, Frame, PinholeCamera, VehicleBox, WorldRaster
from simroad.noise.context import NoiseContext

__all__ = ["SCENE_EGO_SPEED_M_S", "SCENE_POSE", "sample_context", "sample_scene"]

SCENE_POSE = (80.0, 0.0, 0.0)
"""Ego pose of the sample frame: world x, y in m and heading in rad."""
SCENE_EGO_SPEED_M_S = 15.0
"""Ego speed the sample scene's contexts assume, m/s."""
_LEAD = VehicleBox(104.5, -0.5, 0.0, 5.0, 2.0, (200, 30, 30), paint=(0.35, 0.03, 0.03))  # red paint


def sample_scene(seed: int = 0) -> tuple[Frame, PinholeCamera, WorldRaster]:
    """Render the sample frame (320x180) on the racetrack of ``seed``.

    Parameters
    ----------
    seed : int
        Seeds highway-env's reset, the world's palette and textures.

    Returns
    -------
    frame : simroad.camera.Frame
    camera : PinholeCamera
        With the frame's pose set.
    world : WorldRaster
    """
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the environments)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # racetrack-v0 "is out of date"
        env = gym.make("racetrack-v0")
    try:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        world = WorldRaster(cast(Any, env.unwrapped).road.network, rng)
    finally:
        env.close()
    cam = PinholeCamera(CameraConfig(width=320, height=180))
    renderer = CameraRenderer(cam, world, rng)
    return renderer.render(SCENE_POSE, [_LEAD]), cam, world


def sample_context(frame: Frame, camera: PinholeCamera, /, **overrides: Any) -> NoiseContext:
    """The noise context of a sample frame: its camera, depth, materials, vehicles and
    :data:`SCENE_EGO_SPEED_M_S`; ``overrides`` replace any field."""
    kw: dict[str, Any] = dict(
        camera=camera,
        depth=frame.depth,
        material=frame.material,
        vehicles=frame.vehicles,
        ego_speed=SCENE_EGO_SPEED_M_S,
    )
    kw.update(overrides)
    return NoiseContext(**kw)
