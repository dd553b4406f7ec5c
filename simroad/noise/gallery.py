"""The README's weather figure: every noise at three severities on one frame.

``render_gallery(path)`` takes the sample racetrack frame of
:mod:`simroad.noise.scene` (the ego on the first straight, heading world +x, i.e.
towards the glare's default sun) and draws one row per noise: the clean frame and the
noise at severities 1/3, 2/3 and 1. The frame itself is shared with the benchmark and
the tests through :mod:`simroad.noise.scene`; ``gallery_frame`` is its old name.
"""

from __future__ import annotations

import os
import pathlib

import cv2
import numpy as np

from simroad._validation import SimroadError, check_int_in_range, check_output_file
from simroad.noise.compose import make_weather
from simroad.noise.scene import sample_context, sample_scene

__all__ = ["GALLERY_NOISES", "GALLERY_SEVERITIES", "gallery_frame", "render_gallery"]

GALLERY_NOISES = ("rain", "snow", "shadow", "glare", "fog")
GALLERY_SEVERITIES = (1 / 3, 2 / 3, 1.0)

gallery_frame = sample_scene
"""Old name of :func:`simroad.noise.scene.sample_scene` (kept for its callers)."""


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
        raise SimroadError(f"path: expected a .png file name, got {path!r}.")
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


def _write_png(path: pathlib.Path, rgb: np.ndarray) -> None:
    """Write a 256-colour PNG: a median-cut palette with Floyd–Steinberg dithering
    (no banding in smooth glare and fog, about half the size of a true-colour PNG)."""
    from PIL import Image

    img = Image.fromarray(rgb)
    palette = img.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    img.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG).save(path, optimize=True)
