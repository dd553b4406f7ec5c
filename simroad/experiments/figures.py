"""Documentation figures produced by the project itself (``simroad figure ...``)."""

from __future__ import annotations

import os
from pathlib import Path

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.validation import check_int_in_range, check_output_file
from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments._plotting import save_figure, start_figure
from simroad.experiments.rollout import drive_autopilot

__all__ = ["camera_figure", "check_figure_path", "figure_suffixes", "places_figure"]


def figure_suffixes() -> tuple[str, ...]:
    """File extensions matplotlib can write (``.png``, ``.pdf``, ``.svg``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted(f".{ext}" for ext in FigureCanvasBase.get_supported_filetypes()))


def check_figure_path(name: str, path: str | os.PathLike) -> Path:
    """Check, before any drawing, that a figure can be written at ``path``: a file name
    matplotlib knows the type of, in a folder that exists or can be created."""
    return check_output_file(name, path, suffixes=figure_suffixes())


def camera_figure(
    out: str | os.PathLike, *, seed: int = 0, steps: int = 15, camera_profile: CameraProfile | str | None = None
) -> Path:
    """One row per scenario: the clean camera frame, the frame with its ground-truth
    road outline, and the bird's-eye view of the same world. Writes a PNG.
    ``camera_profile`` is RoadCam's (None: simroad's default camera)."""
    out = check_figure_path("out", out)
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1 - len(SCENARIO_NAMES))
    steps = check_int_in_range("steps", steps, 0, 100_000)
    profile = None if camera_profile is None else resolve_profile(camera_profile)
    plt = start_figure(out)
    fig, axes = plt.subplots(
        len(SCENARIO_NAMES), 3, figsize=(11, 2.3 * len(SCENARIO_NAMES)), gridspec_kw={"width_ratios": [16, 16, 6]}
    )
    for row, scenario in enumerate(SCENARIO_NAMES):
        env = RoadCamEnv(scenario=scenario, render_mode="rgb_array", camera_profile=profile)
        obs, _ = env.reset(seed=seed + row)
        if steps > 0:
            obs, _ = drive_autopilot(env, steps)
        panels = (obs, env.render(), env.render_bev(size=(120, 240))[0])
        titles = (f"{scenario}: camera", "ground-truth road outline", "bird's-eye view")
        for ax, img, title in zip(axes[row], panels, titles):
            ax.imshow(img)
            ax.set_title(title, fontsize=9)
            ax.axis("off")
        env.close()
    save_figure(fig, out, dpi=80)
    return out


def places_figure(
    out: str | os.PathLike, *, seed: int = 0, steps: int = 25, camera_profile: CameraProfile | str | None = None
) -> Path:
    """The same places in every scenario, clean and in low sun (shadow 0.9), 640x360.

    One row per scenario: the world of ``seed + row`` after ``steps`` autopilot
    steps, once in clear weather and once under ``noise="shadow"`` at severity 0.9.
    The README shows this figure for simroad 0.1 and for the current world, so that
    a change of the world is seen at the same places. ``camera_profile`` is
    RoadCam's (None: simroad's default camera). Writes a PNG.
    """
    out = check_figure_path("out", out)
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1 - len(SCENARIO_NAMES))
    steps = check_int_in_range("steps", steps, 0, 100_000)
    profile = None if camera_profile is None else resolve_profile(camera_profile)
    plt = start_figure(out)
    n = len(SCENARIO_NAMES)
    fig, axes = plt.subplots(n, 2, figsize=(12.8, 3.7 * n), squeeze=False)
    for row, scenario in enumerate(SCENARIO_NAMES):
        for col, (noise, severity) in enumerate((("clear", 0.0), ("shadow", 0.9))):
            env = RoadCamEnv(
                scenario=scenario, width=640, height=360, noise=noise, severity=severity, camera_profile=profile
            )
            obs, _ = env.reset(seed=seed + row)
            if steps > 0:
                obs, _ = drive_autopilot(env, steps)
            ax = axes[row][col]
            ax.imshow(obs)
            ax.set_title(f"{scenario}, seed {seed + row}: {noise if noise == 'clear' else 'shadow 0.9'}", fontsize=10)
            ax.axis("off")
            env.close()
    save_figure(fig, out, dpi=80)
    return out
