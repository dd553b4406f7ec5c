"""Fixtures of the weather tests: one rendered racetrack frame shared by all tests."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pytest

from simroad.camera import CameraRenderer, Frame, PinholeCamera, WorldRaster
from simroad.experiments.scene import sample_context, sample_scene
from simroad.noise import NoiseContext


@dataclass
class Scene:
    frame: Frame
    camera: PinholeCamera
    world: WorldRaster
    pose: tuple[float, float, float]

    def ctx(self, **kw) -> NoiseContext:
        """A context for the frame (re-setting the camera to the frame's pose)."""
        self.camera.set_pose(*self.pose)
        return sample_context(self.frame, self.camera, **kw)

    def renderer(self) -> tuple[CameraRenderer, PinholeCamera]:
        """A fresh camera and renderer over the same world (for tests that move)."""
        cam = PinholeCamera(self.camera.config)
        return CameraRenderer(cam, self.world, np.random.default_rng(0)), cam


@pytest.fixture(scope="session")
def scene() -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frame, cam, world = sample_scene(seed=3)
    return Scene(frame, cam, world, cam.pose)
