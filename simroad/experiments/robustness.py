"""Physical weather on the user's own photographs: how much of a detector's clean-photo
quality each weather and severity leaves (the corruption-benchmark summary of
ImageNet-C / Cityscapes-C, with simroad's physical weather models).

Each photo is taken as seen by a dashboard camera over flat ground (``hfov_deg``,
``pitch_deg``, ``mount_height_m``; the defaults are :class:`~simroad.camera.CameraConfig`'s),
which gives the models their geometry (ground distance per pixel, the horizon). The
weather of photo ``k`` is drawn from ``numpy.random.default_rng([seed, k])``: the same
photos and seed give the same spoiled photos. Photos larger than the camera's
1280 x 720 are scored at the largest size that fits (colour by area, masks nearest).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from simroad.camera import CameraConfig, PinholeCamera
from simroad.core.validation import check_in_range
from simroad.detector.registry import predict_alone
from simroad.errors import InvalidParameterError
from simroad.experiments.frames import FrameSet
from simroad.filters import format_filters
from simroad.metrics.mask import MaskScore
from simroad.noise import apply_noise, make_weather

__all__ = ["PhotoCamera", "fit_to_camera", "robustness", "robustness_figure", "weathered"]

_DEFAULT = CameraConfig()
#: Largest photo the flat-ground camera takes (CameraConfig's limits).
MAX_SIZE = (1280, 720)


@dataclass(frozen=True)
class PhotoCamera:
    """The mounting a photograph is taken to have (for the weather's geometry)."""

    hfov_deg: float = _DEFAULT.hfov_deg
    pitch_deg: float = _DEFAULT.pitch_deg
    mount_height_m: float = _DEFAULT.mount_height_m

    def camera(self, height: int, width: int) -> PinholeCamera:
        cam = PinholeCamera(
            CameraConfig(
                width=width,
                height=height,
                hfov_deg=self.hfov_deg,
                pitch_deg=self.pitch_deg,
                mount_height_m=self.mount_height_m,
            )
        )
        cam.set_pose(0.0, 0.0, 0.0)
        return cam


def fit_to_camera(frames: FrameSet) -> FrameSet:
    """The photos (and masks) scaled down to fit 1280 x 720 where they are larger."""
    out = FrameSet()
    for k, (img, mask, valid) in enumerate(zip(frames.images, frames.masks, frames.valid, strict=True)):
        h, w = img.shape[:2]
        scale = min(1.0, MAX_SIZE[0] / w, MAX_SIZE[1] / h)
        if h < 16 or w < 16:
            raise InvalidParameterError(f"images: photo {k} is {w}x{h}; the weather needs at least 16x16 pixels.")
        if scale < 1.0:
            size = (max(16, int(w * scale)), max(16, int(h * scale)))
            img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
            mask = cv2.resize(mask.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
            valid = cv2.resize(valid.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
        out.images.append(img)
        out.masks.append(mask)
        out.valid.append(valid)
        out.noise_masks.append({})
        out.source.append(frames.source[k] if k < len(frames.source) else ("photo", 0, k))
    return out


def weathered(
    frames: FrameSet, noise: str, severity: float, *, seed: int = 0, mount: PhotoCamera = PhotoCamera()
) -> FrameSet:
    """``frames`` with the weather ``noise`` at ``severity`` on every photo (see the
    module docstring); masks and valid pixels unchanged, the weather's masks kept."""
    make_weather(noise, severity=severity)  # a bad spec fails before any photo
    out = FrameSet()
    cameras: dict[tuple[int, int], PinholeCamera] = {}
    for k, img in enumerate(frames.images):
        h, w = img.shape[:2]
        cam = cameras.setdefault((h, w), mount.camera(h, w))
        noisy, masks = apply_noise(img, noise, severity=severity, rng=np.random.default_rng([int(seed), k]), camera=cam)
        out.images.append(noisy)
        out.masks.append(frames.masks[k])
        out.valid.append(frames.valid[k])
        out.noise_masks.append(masks)
        out.source.append(frames.source[k] if k < len(frames.source) else ("photo", 0, k))
    return out


def _score(frames: FrameSet, detector: Any) -> dict[str, float]:
    score = MaskScore()
    for img, gt, valid in zip(frames.images, frames.masks, frames.valid, strict=True):
        score.update(predict_alone(detector, img), gt, valid=valid)
    s = score.summary()
    return {"frames": score.n_frames, **{k: float(s[k]) for k in ("fnr", "fpr", "iou")}}


def robustness(
    frames: FrameSet,
    settings: Sequence[tuple[str, ...]],
    noises: Sequence[str],
    severities: Sequence[float],
    factory: Callable[[tuple[str, ...]], Any],
    *,
    seed: int = 0,
    mount: PhotoCamera = PhotoCamera(),
) -> tuple[list[dict], list[dict]]:
    """Score every filter setting on the clean photos and under each weather.

    Returns
    -------
    rows : list of dict
        One per setting x (clear, or noise x severity): ``filters``, ``noise``,
        ``severity``, ``frames``, ``fnr``, ``fpr``, ``iou`` and ``retained``, the IoU
        as a share of the same setting's clean IoU.
    summary : list of dict
        One per setting x noise: ``filters``, ``noise``, ``clean_iou`` and
        ``mean_retained``, the mean of ``retained`` over the severities.
    """
    sevs = [check_in_range("severity", s, 0.0, 1.0) for s in severities]
    if not sevs or not noises:
        raise InvalidParameterError("noises, severities: give at least one weather and one severity.")
    spoiled = {(n, s): weathered(frames, n, s, seed=seed, mount=mount) for n in noises for s in sevs}
    rows, summary = [], []
    for filters in settings:
        det = factory(tuple(filters))
        label = format_filters(filters)
        clean = _score(frames, det)
        rows.append({"filters": label, "noise": "clear", "severity": 0.0, **clean, "retained": 1.0})
        for n in noises:
            kept = []
            for s in sevs:
                sc = _score(spoiled[(n, s)], det)
                retained = sc["iou"] / clean["iou"] if clean["iou"] > 0 else math.nan
                kept.append(retained)
                rows.append({"filters": label, "noise": n, "severity": s, **sc, "retained": retained})
            summary.append(
                {"filters": label, "noise": n, "clean_iou": clean["iou"], "mean_retained": float(np.nanmean(kept))}
            )
    return rows, summary


def robustness_figure(rows: list[dict], path: str | Path) -> Path:
    """Retained share of the clean IoU against severity, one panel per weather, one
    line per filter setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    noises = sorted({r["noise"] for r in rows if r["noise"] != "clear"})
    settings = list(dict.fromkeys(r["filters"] for r in rows))
    fig, axes = plt.subplots(1, max(1, len(noises)), figsize=(3.4 * max(1, len(noises)), 3.2), squeeze=False)
    for ax, noise in zip(axes[0], noises, strict=False):
        for f in settings:
            pts = sorted((r["severity"], r["retained"]) for r in rows if r["filters"] == f and r["noise"] == noise)
            ax.plot([0.0] + [p[0] for p in pts], [1.0] + [p[1] for p in pts], marker="o", label=f"filters: {f}")
        ax.set_title(noise)
        ax.set_xlabel("severity")
        ax.set_ylim(0.0, 1.05)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("IoU retained (share of clean)")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
