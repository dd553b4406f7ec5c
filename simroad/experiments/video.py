"""Record an episode as an annotated video: what a person looks at to understand a failure.

Each frame is the (noisy) camera view with the predicted road mask tinted green,
the ground-truth road outline in yellow, and a bird's-eye inset (top right) of the
world with the ego's trajectory so far; optionally, on its left, the same frame with a
second mask (the detector with other filters: without/with filters side by side). ``.mp4`` is written with imageio's ffmpeg
plugin, ``.gif`` with Pillow.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from simroad.errors import InvalidParameterError

__all__ = ["EpisodeVideo", "overlay_frame"]


def overlay_frame(obs: np.ndarray, gt: np.ndarray, pred: np.ndarray | None) -> np.ndarray:
    """The view with the predicted mask tinted green and the GT outline in yellow.

    Parameters
    ----------
    obs : ndarray (H, W, 3), uint8
        The camera frame (RGB); not modified.
    gt : ndarray (H, W), bool
        Ground-truth road mask; its outline is drawn 1 pixel wide in (255, 230, 0).
    pred : ndarray (H, W), bool, optional
        Predicted road mask; its pixels become 0.6 x view + 0.4 x (40, 220, 60).

    Returns
    -------
    ndarray (H, W, 3), uint8
        A new annotated frame.
    """
    out = obs.copy()
    if pred is not None:
        tint = out[pred].astype(np.float32)
        out[pred] = (0.6 * tint + 0.4 * np.array([40, 220, 60], np.float32)).astype(np.uint8)
    contours, _ = cv2.findContours(gt.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(out, contours, -1, (255, 230, 0), 1)
    return out


class EpisodeVideo:
    """Collect annotated frames of an episode and write them to ``path``."""

    def __init__(
        self, path: str | os.PathLike, env, *, fps: int = 5, caption: str = "", labels: tuple[str, str] = ("", "")
    ) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() not in (".mp4", ".gif"):
            raise InvalidParameterError(f"video: expected a path ending in .mp4 or .gif, got {str(self.path)!r}.")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InvalidParameterError(f"video: cannot create {str(self.path.parent)!r} ({exc.strerror}).") from None
        self.env = env
        self.fps = fps
        self.caption = str(caption)
        self._caption_at: tuple[float, int, int, int] | None = None
        self.frames: list[np.ndarray] = []
        self.trail: list[np.ndarray] = []
        #: Labels of the two views when frames come with a mask ``beside`` (left, right).
        self.labels = (str(labels[0]), str(labels[1]))
        self._labels_at: list[tuple[float, int, int, int]] = []

    def add(self, obs: np.ndarray, info: dict, pred: np.ndarray | None, *, beside: np.ndarray | None = None) -> None:
        """Append one annotated frame: ``obs`` (H, W, 3) uint8 with ``pred`` (H, W) bool
        tinted, the outline of ``info["road_mask"]``, and the bird's-eye inset with the
        trajectory up to ``info["pose"]`` (x m, y m, heading rad). With ``beside`` (a
        second mask of the same frame), the frame is two views side by side: ``beside``
        on the left, ``pred`` on the right, each labelled with :attr:`labels`."""
        frame = overlay_frame(obs, info["road_mask"], pred)
        self.trail.append(np.asarray(info["pose"][:2], dtype=float))
        h = frame.shape[0]
        size = (max(32, h * 2 // 5), max(32, h * 3 // 5))
        mpp = 0.5
        bev, _ = self.env.render_bev(size=size, metres_per_px=mpp)
        self._draw_trail(bev, info["pose"], mpp, behind_m=15.0)
        cv2.rectangle(bev, (0, 0), (size[0] - 1, size[1] - 1), (255, 255, 255), 1)
        frame[: size[1], -size[0] :] = bev
        if self.caption:
            if self._caption_at is None:  # laid out once: every frame of a video has one size
                self._caption_at = _caption_layout(frame.shape[0], self.caption, width=frame.shape[1] - size[0] - 4)
            _draw_caption(frame, self.caption, *self._caption_at)
        if beside is not None:
            left = overlay_frame(obs, info["road_mask"], beside)
            if not self._labels_at:  # laid out once, as the caption
                self._labels_at = [_caption_layout(h, text, width=frame.shape[1] - 4) for text in self.labels]
            for view, text, at in zip((left, frame), self.labels, self._labels_at, strict=True):
                if text:
                    _draw_label(view, text, *at)
            frame = np.concatenate([left, np.full((h, 2, 3), 255, np.uint8), frame], axis=1)
        self.frames.append(frame)

    def _draw_trail(self, bev: np.ndarray, pose: np.ndarray, mpp: float, behind_m: float) -> None:
        if len(self.trail) < 2:
            return
        W, H = bev.shape[1], bev.shape[0]
        x, y, hd = (float(v) for v in pose)
        fwd = np.array([math.cos(hd), math.sin(hd)])
        right = np.array([-math.sin(hd), math.cos(hd)])
        d = np.asarray(self.trail) - (x, y)
        cols = W / 2.0 + (d @ right) / mpp
        rows = H - behind_m / mpp - (d @ fwd) / mpp
        pts = np.round(np.column_stack([cols, rows])).astype(np.int32)
        cv2.polylines(bev, [pts], False, (255, 60, 60), 1)

    def close(self) -> Path:
        """Write the file and return its path."""
        import imageio.v2 as imageio

        frames: list[npt.ArrayLike] = list(self.frames)
        if not frames:
            raise InvalidParameterError("video: the episode produced no frames.")
        try:
            if self.path.suffix.lower() == ".gif":
                imageio.mimsave(self.path, frames, duration=1.0 / self.fps, loop=0)
            else:
                imageio.mimsave(self.path, frames, fps=self.fps, macro_block_size=1)
        except (OSError, ValueError, RuntimeError) as exc:
            raise InvalidParameterError(f"video: could not write {str(self.path)!r}: {exc}") from None
        return self.path


def _caption_layout(height: int, text: str, *, width: int) -> tuple[float, int, int, int]:
    """(font scale, text width, text height, baseline) of a caption that fits ``width``
    pixels on frames ``height`` pixels tall."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    (w, _), _ = cv2.getTextSize(text, font, 1.0, 1)
    scale = max(0.25, min(0.5, height / 500.0, width / max(w, 1)))
    (w, h), base = cv2.getTextSize(text, font, scale, 1)
    return scale, w, h, base


def _draw_caption(frame: np.ndarray, text: str, scale: float, w: int, h: int, base: int) -> None:
    """Write ``text`` on a dark band at the top left of ``frame`` (in place)."""
    frame[: h + base + 4, : min(w + 6, frame.shape[1])] //= 3
    cv2.putText(frame, text, (3, h + 2), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)


def _draw_label(frame: np.ndarray, text: str, scale: float, w: int, h: int, base: int) -> None:
    """Write ``text`` (laid out by :func:`_caption_layout`) on a dark band at the bottom left of ``frame`` (in place)."""
    top = frame.shape[0] - h - base - 4
    frame[top:, : min(w + 6, frame.shape[1])] //= 3
    cv2.putText(frame, text, (3, frame.shape[0] - base - 2), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1,
                cv2.LINE_AA)  # fmt: skip
