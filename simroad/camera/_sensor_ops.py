"""Pure per-frame operations of the camera sensor: vignetting, motion blur, noise, tone curve, JPEG.

Each is a function of arrays and physical parameters; :mod:`simroad.camera.sensor`
composes them in physical order (see its docstring and docs/camera.md).
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad._validation import SimroadError

__all__ = [
    "jpeg_roundtrip",
    "motion_blur_lengths",
    "response_curve",
    "shot_read_noise",
    "vertical_motion_blur",
    "vignetting_gain",
]


def vignetting_gain(height: int, width: int, focal_px: float, cx: float, cy: float) -> np.ndarray:
    """cos^4 of each pixel's field angle: ``(f^2 / (f^2 + r^2))^2``.

    Parameters
    ----------
    height, width : int
        Image size in pixels.
    focal_px : float
        Focal length in pixels.
    cx, cy : float
        Principal point in pixels (column, row).

    Returns
    -------
    ndarray, float32, (H, W)
        Relative illumination in (0, 1], 1 on the optical axis.
    """
    return _vignetting_gain(int(height), int(width), float(focal_px), float(cx), float(cy))


def _vignetting_gain(height: int, width: int, focal_px: float, cx: float, cy: float) -> np.ndarray:
    # One map per camera: computed once, shared read-only by every frame.
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    r2 = (u - cx) ** 2 + (v - cy) ** 2
    f2 = focal_px * focal_px
    gain = ((f2 / (f2 + r2)) ** 2).astype(np.float32)
    gain.flags.writeable = False
    return gain


def motion_blur_lengths(
    height: int,
    *,
    focal_px: float,
    mount_height_m: float,
    horizon_row: float,
    speed_m_s: float,
    exposure_s: float,
    depth: np.ndarray | None = None,
) -> np.ndarray:
    """Vertical image motion of each row's ground during the exposure, in pixels.

    A ground point at distance ``Z0`` (m) approaches by ``v T`` metres, so its image
    row moves by ``f h (1/Z1 - 1/Z0)`` with ``Z1 = Z0 - v T``. ``Z0`` is the row's
    median finite ``depth`` when the depth map is given, else ``f h / (row -
    horizon)``. Rows at or above the horizon (sky) do not move.

    Parameters
    ----------
    height : int
        Number of image rows.
    focal_px : float
        Focal length in pixels.
    mount_height_m : float
        Camera height above the ground in metres.
    horizon_row : float
        Image row of the horizon.
    speed_m_s : float
        Ego forward speed in m/s (negative values are treated as their magnitude).
    exposure_s : float
        Exposure time in seconds.
    depth : ndarray, float32, (H, W), optional
        Ground distance in metres, ``inf`` where there is no ground.

    Returns
    -------
    ndarray, float64, (H,)
        Blur length per row in pixels (0 where nothing moves).
    """
    fh = focal_px * mount_height_m
    rows = np.arange(height, dtype=np.float64)
    if depth is not None:
        d = np.where(np.isfinite(depth), depth, np.nan).astype(np.float64)
        valid = np.isfinite(d).any(axis=1)
        z0 = np.full(height, np.inf)
        if valid.any():
            z0[valid] = np.nanmedian(d[valid], axis=1)
    else:
        below = rows - horizon_row
        z0 = np.where(below > 0, fh / np.maximum(below, 1e-12), np.inf)
    travel = abs(float(speed_m_s)) * float(exposure_s)
    out = np.zeros(height)
    if travel == 0.0:
        return out
    ok = np.isfinite(z0) & (z0 > 0)
    z1 = np.maximum(z0[ok] - travel, 1e-3)
    out[ok] = fh * (1.0 / z1 - 1.0 / z0[ok])
    return np.minimum(out, float(height))


def vertical_motion_blur(lin: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Average each row over the ``lengths[row]`` rows above it (a box, sub-pixel exact).

    Ground moves down the image as the car advances, so a pixel integrates the
    radiance of the rows above it during the exposure. The window ``[y + 1 - L, y + 1]``
    of the piecewise-constant image is integrated exactly.

    Parameters
    ----------
    lin : ndarray, float32, (H, W, C)
        Linear radiance (not modified).
    lengths : ndarray, (H,)
        Blur length per row in pixels, >= 0.

    Returns
    -------
    ndarray, float32, (H, W, C)
    """
    if not np.any(lengths > 1e-6):
        return lin.copy()
    h = lin.shape[0]
    csum = np.zeros((h + 1, *lin.shape[1:]), dtype=np.float64)
    np.cumsum(lin, axis=0, out=csum[1:])
    end = np.arange(1, h + 1, dtype=np.float64)
    start = np.maximum(end - np.asarray(lengths, dtype=np.float64), 0.0)
    i = np.minimum(np.floor(start).astype(np.int64), h - 1)
    frac = (start - i)[:, None, None]
    c_start = csum[i] + frac * lin[i]
    width = np.maximum(end - start, 1e-12)[:, None, None]
    out = (csum[1:] - c_start) / width
    still = lengths <= 1e-6
    out[still] = lin[still]
    return out.astype(np.float32)


def shot_read_noise(electrons: np.ndarray, rng: np.random.Generator, *, shot: bool, read_noise_e: float) -> np.ndarray:
    """Add photon shot noise (variance = mean, in e-) and Gaussian read noise (EMVA 1288).

    Parameters
    ----------
    electrons : ndarray, float32, (H, W, C)
        Expected signal in electrons (not modified).
    rng : numpy.random.Generator
    shot : bool
        Add shot noise (normal approximation of the Poisson law).
    read_noise_e : float
        Read noise standard deviation in electrons.

    Returns
    -------
    ndarray, float32, (H, W, C)
        Noisy signal in electrons (may be negative before clipping).
    """
    out = electrons.astype(np.float32, copy=True)
    if not shot and read_noise_e == 0.0:
        return out
    var = np.maximum(electrons, 0.0) if shot else np.zeros_like(out)
    sigma = np.sqrt(var + np.float32(read_noise_e) ** 2, dtype=np.float32)
    out += sigma * rng.standard_normal(out.shape, dtype=np.float32)
    return out


def response_curve(y: np.ndarray, *, shoulder: float, gamma: float) -> np.ndarray:
    """The camera response: ``((1 + k) y / (1 + k y)) ** gamma`` on ``y`` in [0, 1].

    Maps 0 to 0 and 1 to 1; the shoulder ``k`` lifts shadows and compresses
    highlights as a filmic curve does.
    """
    y = np.clip(y, 0.0, 1.0).astype(np.float32)
    if shoulder > 0.0:
        y = (np.float32(1.0 + shoulder) * y) / (np.float32(1.0) + np.float32(shoulder) * y)
    if gamma != 1.0:
        y = np.power(y, np.float32(gamma), dtype=np.float32)
    return y


def jpeg_roundtrip(rgb: np.ndarray, quality: int) -> np.ndarray:
    """Encode and decode an RGB uint8 frame as JPEG at ``quality`` (1..100)."""
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
    if decoded is None:
        raise SimroadError("jpeg_quality: OpenCV could not encode and decode the frame as JPEG.")
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)
