"""Documentation figures produced by the project itself (``simroad figure ...``)."""

from __future__ import annotations

import os
from pathlib import Path

from simroad._validation import check_int_in_range, check_output_file
from simroad.envs import SCENARIO_NAMES, RoadCamEnv
from simroad.experiments.export import ensure_writable_dir
from simroad.experiments.rollout import drive_autopilot

__all__ = ["camera_figure", "check_figure_path", "figure_suffixes"]


def figure_suffixes() -> tuple[str, ...]:
    """File extensions matplotlib can write (``.png``, ``.pdf``, ``.svg``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted(f".{ext}" for ext in FigureCanvasBase.get_supported_filetypes()))


def check_figure_path(name: str, path: str | os.PathLike) -> Path:
    """Check, before any drawing, that a figure can be written at ``path``: a file name
    matplotlib knows the type of, in a folder that exists or can be created."""
    return check_output_file(name, path, suffixes=figure_suffixes())


def camera_figure(out: str | os.PathLike, *, seed: int = 0, steps: int = 15) -> Path:
    """One row per scenario: the clean camera frame, the frame with its ground-truth
    road outline, and the bird's-eye view of the same world. Writes a PNG."""
    out = check_figure_path("out", out)
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1 - len(SCENARIO_NAMES))
    steps = check_int_in_range("steps", steps, 0, 100_000)
    import matplotlib  # lazily: selecting the Agg backend must precede pyplot, and only when drawing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ensure_writable_dir("out", out.parent if str(out.parent) else ".")
    fig, axes = plt.subplots(
        len(SCENARIO_NAMES), 3, figsize=(11, 2.3 * len(SCENARIO_NAMES)), gridspec_kw={"width_ratios": [16, 16, 6]}
    )
    for row, scenario in enumerate(SCENARIO_NAMES):
        env = RoadCamEnv(scenario=scenario, render_mode="rgb_array")
        obs, _ = env.reset(seed=seed + row)
        if steps > 0:
            obs, _ = drive_autopilot(env, steps)
        panels = (obs, env.render(), env.render_bev(size=(120, 240)))
        titles = (f"{scenario}: camera", "ground-truth road outline", "bird's-eye view")
        for ax, img, title in zip(axes[row], panels, titles):
            ax.imshow(img)
            ax.set_title(title, fontsize=9)
            ax.axis("off")
        env.close()
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out
