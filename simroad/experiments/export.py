"""Frame export: a ready data set of camera frames and ground-truth road masks."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from tqdm import tqdm

from simroad.camera.codes import CITYSCAPES_LABEL_ID, CITYSCAPES_LABELS, MATERIAL_NAMES
from simroad.core.validation import check_int_in_range, check_output_dir, ensure_writable_dir
from simroad.envs import RoadCamEnv
from simroad.errors import InvalidParameterError
from simroad.experiments.rollout import drive_autopilot

__all__ = ["FILES", "export_frames"]

#: What each file of a frame holds (``N`` the frame's 4-digit index).
FILES = {
    "frame_N.png": "RGB camera frame, 8-bit sRGB",
    "road_N.png": "ground-truth road mask: 255 road (asphalt and markings on visible ground), 0 not",
    "depth_N.png": "16-bit depth, centimetres (metres = value / 100): the ground distance along the view "
    "to the ground or object each pixel sees; 0 for the sky and beyond the camera's max_range_m",
    "material_N.png": "8-bit material code of each pixel (meta.json 'materials' names them)",
    "labels_N.png": "8-bit Cityscapes labelId of each pixel (meta.json 'cityscapes_label_ids')",
    "noise_<name>_N.png": "255 where that weather changed the frame (rain, snow, shadow, glare, fog, ...; "
    "windscreen: drops and the wiper on the glass), 0 elsewhere; only the masks the weather has",
}


def _write_png(path: Path, rgb_or_grey: np.ndarray) -> None:
    img = rgb_or_grey if rgb_or_grey.ndim == 2 else cv2.cvtColor(rgb_or_grey, cv2.COLOR_RGB2BGR)
    if not cv2.imwrite(str(path), img):
        raise InvalidParameterError(f"out: could not write {str(path)!r}. Check free space and permissions.")


def _depth_centimetres(depth: np.ndarray) -> np.ndarray:
    """``depth`` (float metres, inf where nothing is in range) as uint16 centimetres, 0 for none."""
    cm = np.rint(np.where(np.isfinite(depth), depth, 0.0) * 100.0)
    return np.clip(cm, 0, np.iinfo(np.uint16).max).astype(np.uint16)


def export_frames(
    out: str | os.PathLike,
    *,
    seed: int = 0,
    count: int = 50,
    every: int = 1,
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
) -> Path:
    """Drive the ground-truth autopilot and write frames, their ground truth and ``meta.json``.

    Files per frame ``N`` (formats in :data:`FILES`, also written to ``meta.json``):
    ``frame_N.png`` (RGB camera frame), ``road_N.png`` (road mask, 0/255),
    ``depth_N.png`` (16-bit, centimetres, 0 where no ground or object is in range),
    ``material_N.png`` (simroad's material codes), ``labels_N.png`` (Cityscapes label
    ids) and ``noise_<name>_N.png`` (0/255, one per mask of the weather: its noise
    names and ``windscreen``). ``meta.json`` holds the camera intrinsics and mounting,
    the environment options, the ego pose of every frame, the file formats, the
    material names and the Cityscapes id of each material.

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
        _write_png(out_dir / f"depth_{k:04d}.png", _depth_centimetres(info["depth"]))
        _write_png(out_dir / f"material_{k:04d}.png", info["material"])
        _write_png(out_dir / f"labels_{k:04d}.png", CITYSCAPES_LABELS[info["material"]])
        for name, mask in info["noise_masks"].items():
            _write_png(out_dir / f"noise_{name}_{k:04d}.png", mask.astype(np.uint8) * 255)
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
        "files": FILES,
        "materials": {str(code): name for code, name in MATERIAL_NAMES.items()},
        "cityscapes_label_ids": {MATERIAL_NAMES[code]: label for code, label in CITYSCAPES_LABEL_ID.items()},
    }
    (out_dir / "meta.json").write_text(json.dumps(meta, indent=1))
    env.close()
    return out_dir
