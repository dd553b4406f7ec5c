"""Frame export: a ready data set of camera frames and ground-truth road masks."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from tqdm import tqdm

from simroad.core.validation import check_int_in_range, check_output_dir, ensure_writable_dir
from simroad.envs import RoadCamEnv
from simroad.errors import InvalidParameterError
from simroad.experiments.rollout import drive_autopilot

__all__ = ["export_frames"]


def _write_png(path: Path, rgb_or_grey: np.ndarray) -> None:
    img = rgb_or_grey if rgb_or_grey.ndim == 2 else cv2.cvtColor(rgb_or_grey, cv2.COLOR_RGB2BGR)
    if not cv2.imwrite(str(path), img):
        raise InvalidParameterError(f"out: could not write {str(path)!r}. Check free space and permissions.")


def export_frames(
    out: str | os.PathLike,
    *,
    seed: int = 0,
    count: int = 50,
    every: int = 1,
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
) -> Path:
    """Drive the ground-truth autopilot and write frames, GT masks and ``meta.json``.

    Files: ``frame_0000.png`` (RGB camera frame), ``road_0000.png`` (GT road mask,
    0/255), and ``meta.json`` with the camera intrinsics and mounting, the
    environment options and the ego pose of every frame.

    Parameters
    ----------
    out : path
        Output directory (created).
    seed : int
        Episode seed.
    count : int
        Number of frames, in [1, 100000].
    every : int
        Policy steps between exported frames, in [1, 1000].
    env_kwargs : dict
        Keyword arguments of ``simroad/RoadCam-v0`` (scenario, noise, width, ...).
    """
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1)
    count = check_int_in_range("count", count, 1, 100_000)
    every = check_int_in_range("every", every, 1, 1000)
    if env_kwargs is not None and not isinstance(env_kwargs, dict):
        raise InvalidParameterError(f"env_kwargs: expected a dict of RoadCam options, got {type(env_kwargs).__name__}.")
    check_output_dir("out", out)
    env = RoadCamEnv(**(env_kwargs or {}))  # validate every option before touching the disk
    out_dir = ensure_writable_dir("out", out)
    obs, info = env.reset(seed=int(seed))
    cam = env.camera
    frames_meta = []
    for k in tqdm(range(count), disable=not progress, desc="frames", unit="frame"):
        if k > 0:
            obs, info = drive_autopilot(env, every, reset_seed=int(seed) + k)
        _write_png(out_dir / f"frame_{k:04d}.png", obs)
        _write_png(out_dir / f"road_{k:04d}.png", info["road_mask"].astype(np.uint8) * 255)
        x, y, h = (float(v) for v in info["pose"])
        frames_meta.append(
            {"index": k, "x_m": x, "y_m": y, "heading_rad": h, "time_s": info["time_s"], "speed_m_s": info["speed_m_s"]}
        )
    c = cam.config
    meta = {
        "seed": int(seed),
        "env": {
            **{k: v for k, v in (env_kwargs or {}).items() if isinstance(v, (str, int, float, bool, type(None)))},
            "noise": env.config.noise,
            "severity": env.config.severity if env.config.noise != "clear" else 0.0,  # clear has no severity
        },
        "camera_profile": env.config.camera_profile.as_dict() if env.config.camera_profile is not None else None,
        "camera": {
            "width": c.width,
            "height": c.height,
            "K": cam.K.tolist(),
            "hfov_deg": c.hfov_deg,
            "mount_height_m": c.mount_height_m,
            "pitch_deg": c.pitch_deg,
            "forward_offset_m": c.forward_offset_m,
            "max_range_m": c.max_range_m,
        },
        "frames": frames_meta,
    }
    (out_dir / "meta.json").write_text(json.dumps(meta, indent=1))
    env.close()
    return out_dir
