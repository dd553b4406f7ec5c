"""The README's weather figures: every noise at three severities on one frame, and a
wiper pass on a wet windscreen.

``render_gallery(path)`` takes the sample racetrack frame of
:mod:`simroad.experiments.scene` (the ego on the first straight, heading world +x, i.e.
towards the glare's default sun) and draws one row per noise: the clean frame and the
noise at severities 1/3, 2/3 and 1. The frame itself is shared with the benchmark and
the tests through :mod:`simroad.experiments.scene`.

``render_wiper_sequence(path)`` drives a camera along highway-env's straight road in
rain and draws frames before, during and after a wiper cycle
(:mod:`simroad.noise.windscreen`).
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
from typing import Any, cast

import cv2
import numpy as np

from simroad.camera import CameraConfig, CameraRenderer, PinholeCamera, VehicleBox, WorldRaster
from simroad.core.names import NOISE_NAMES
from simroad.core.validation import check_int_in_range, check_output_file
from simroad.errors import InvalidParameterError
from simroad.experiments.scene import sample_context, sample_scene
from simroad.noise._windscreen_params import WindscreenParams
from simroad.noise.compose import make_weather
from simroad.noise.context import NoiseContext
from simroad.noise.windscreen import WindscreenModel

__all__ = ["GALLERY_NOISES", "GALLERY_SEVERITIES", "render_gallery", "render_wiper_sequence"]

GALLERY_NOISES = tuple(name for name in NOISE_NAMES if name != "clear")
GALLERY_SEVERITIES = (1 / 3, 2 / 3, 1.0)


def _label(tile: np.ndarray, text: str) -> np.ndarray:
    out = tile.copy()
    cv2.rectangle(out, (0, 0), (8 + 8 * len(text), 18), (0, 0, 0), -1)
    cv2.putText(out, text, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def render_gallery(path: str | os.PathLike, *, seed: int = 0) -> pathlib.Path:
    """Render clean + each noise at severities 1/3, 2/3, 1 into one PNG.

    Parameters
    ----------
    path : str or PathLike
        Output file; must end in ``.png``. Parent directories are created.
    seed : int
        Seeds the world, the palette and every noise model.

    Returns
    -------
    pathlib.Path
        The written file (a palette PNG, a few hundred kB).
    """
    if not isinstance(path, (str, os.PathLike)) or pathlib.Path(path).suffix.lower() != ".png":
        raise InvalidParameterError(f"path: expected a .png file name, got {path!r}.")
    path = check_output_file("path", path, suffixes=(".png",))  # before any rendering
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1)
    frame, cam, world = sample_scene(seed)
    ctx = sample_context(frame, cam)
    rows = []
    for k, name in enumerate(GALLERY_NOISES):
        tiles = [_label(frame.rgb, "clean")]
        for s in GALLERY_SEVERITIES:
            weather = make_weather(name, severity=s)
            weather.reset(np.random.default_rng([seed, k]), world=world)
            noisy, _ = weather.apply(frame.rgb, ctx)
            tiles.append(_label(noisy, f"{name} {s:.2f}"))
        rows.append(np.hstack(tiles))
    grid = np.vstack(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_png(path, grid)
    return path


def render_wiper_sequence(
    path: str | os.PathLike, *, seed: int = 0, severity: float = 0.6, size: tuple[int, int] = (480, 270)
) -> pathlib.Path:
    """Frames before, during and after a wiper pass in rain, into one PNG.

    The camera drives at 20 m/s along highway-env's straight ``highway-v0`` road behind
    a car at the same speed, in rain of ``severity`` with a wiper every 4 s, at 30
    frames/s; the
    figure shows 8 of them (two rows): the wet glass, the blade's up-stroke across the
    view, the glass it left, the down-stroke, the clean glass, and the drops that
    gather again over the next 2 s. Each panel is labelled with its time from the
    start of the wipe.

    Parameters
    ----------
    path : str or PathLike
        Output file; must end in ``.png``. Parent directories are created.
    seed : int
        Seeds the world and the weather.
    severity : float
        Rain severity in (0, 1].
    size : tuple of int
        ``(width, height)`` of each frame in pixels.

    Returns
    -------
    pathlib.Path
    """
    if not isinstance(path, (str, os.PathLike)) or pathlib.Path(path).suffix.lower() != ".png":
        raise InvalidParameterError(f"path: expected a .png file name, got {path!r}.")
    path = check_output_file("path", path, suffixes=(".png",))
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1)
    frames, times, picks = _wiper_frames(seed, severity, size)
    tiles = [_label(frames[k], f"{times[k]:+.2f} s{' (blade)' if blade else ''}") for k, blade in picks]
    grid = np.vstack([np.hstack(tiles[:4]), np.hstack(tiles[4:8])])
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_png(path, grid)
    return path


def _highway_world(seed: int):
    """The world of highway-env's straight four-lane ``highway-v0`` road (for seed)."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the environments)

    env = gym.make("highway-v0")
    try:
        env.reset(seed=seed)
        return WorldRaster(cast(Any, env.unwrapped).road.network, np.random.default_rng(seed))
    finally:
        env.close()


def _wiper_frames(seed: int, severity: float, size: tuple[int, int]) -> tuple[list, list, list]:
    """Render 6 s of rain at 30 frames/s on a straight road; pick 8 frames around the
    first wipe: (frames, times from the wipe's start, [(index, blade in view)])."""

    world = _highway_world(seed)
    cam = PinholeCamera(CameraConfig(width=size[0], height=size[1]))
    renderer = CameraRenderer(cam, world, np.random.default_rng(seed))
    weather = make_weather("rain", severity=severity, windscreen=WindscreenParams(wiper_period_s=4.0))
    weather.reset(np.random.default_rng([seed, 17]), world=world)
    glass = cast(WindscreenModel, weather.models["windscreen"])
    lead = VehicleBox(130.0, 4.0, 0.0, 5.0, 2.0, (200, 30, 30), paint=(0.35, 0.03, 0.03))
    frames, blade = [], []
    for k in range(6 * 30):
        dx = 20.0 * k / 30  # both cars at 20 m/s in the second lane
        frame = renderer.render((100.0 + dx, 4.0, 0.0), [dataclasses.replace(lead, x=lead.x + dx)])
        ctx = NoiseContext(
            camera=cam,
            depth=frame.depth,
            material=frame.material,
            vehicles=frame.vehicles,
            ego_speed=20.0,
            dt=1 / 30,
            time_s=k / 30,
        )
        frames.append(weather.apply(frame.rgb, ctx)[0])
        blade.append(glass.blade_visible)
    up = blade.index(True)
    up_end = up + blade[up:].index(False)
    down = up_end + blade[up_end:].index(True)
    done = down + blade[down:].index(False)
    picks = [up - 6, up + (up_end - up) // 2, up_end + 2, down + (done - down) // 2]
    picks += [done + 1, done + 15, done + 30, done + 60]
    start = up - 1
    return frames, [(k - start) / 30 for k in range(len(frames))], [(k, blade[k]) for k in picks]


def _write_png(path: pathlib.Path, rgb: np.ndarray) -> None:
    """Write a 256-colour PNG: a median-cut palette with Floyd–Steinberg dithering
    (no banding in smooth glare and fog, about half the size of a true-colour PNG)."""
    from PIL import Image

    img = Image.fromarray(rgb)
    palette = img.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    img.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG).save(path, optimize=True)
