"""The camera sensor: the last stage of the camera, after the weather (DESIGN.md §8).

The rendered (and weathered) sRGB frame is decoded to linear scene radiance, then
goes through what a real automotive camera does to it, in physical order:

1. motion blur from the ego's forward speed during the exposure (per image row);
2. vignetting, the cos^4 law of the field angle;
3. exposure (nominal exposure time times the auto-exposure gain ``2**ev``) into
   electrons, with photon shot noise and read noise (EMVA 1288's linear model),
   saturating at the full-well capacity;
4. the camera response curve (a highlight shoulder and a gamma) and sRGB encoding;
5. optionally JPEG compression.

The maths are pure functions; :class:`Sensor` only holds the auto-exposure state and
the random generator of one episode. ``SensorParams.none()`` is the identity.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from simroad._validation import SimroadError, check_bool, check_in_range, check_int_in_range
from simroad.camera.geometry import PinholeCamera
from simroad.noise.radiometry import linear_to_srgb, srgb_to_linear

__all__ = [
    "Sensor",
    "SensorParams",
    "apply_sensor",
    "auto_exposure_update",
    "jpeg_roundtrip",
    "motion_blur_lengths",
    "response_curve",
    "shot_read_noise",
    "vertical_motion_blur",
    "vignetting_gain",
]


@dataclass(frozen=True)
class SensorParams:
    """Physical parameters of the camera sensor (docs/camera.md).

    Parameters
    ----------
    exposure_time_s : float
        Nominal exposure time in seconds, in (0, 0.1]. A linear radiance of 1.0
        (white) fills the full well at this exposure and ``ev = 0``.
    auto_exposure : bool
        Adapt the exposure over frames towards ``ae_target_mean``.
    ae_target_mean : float
        Target mean of the exposed linear signal (fraction of full well), in (0, 1);
        0.18 is photographic middle grey.
    ae_rate : float
        Fraction of the log2 exposure error corrected per frame, in (0, 1].
    ev_min, ev_max : float
        Limits of the auto-exposure in stops (EV) relative to the nominal exposure,
        ``ev_min`` in [-10, 0], ``ev_max`` in [0, 10]. The exposure time is
        ``exposure_time_s * 2**ev``.
    tone_shoulder : float
        Strength ``k`` of the response curve's shoulder ``(1 + k) y / (1 + k y)``,
        in [0, 20]; 0 is a linear response.
    gamma : float
        Extra exponent on the normalised signal before sRGB encoding, in [0.2, 5];
        1.0 is plain sRGB.
    full_well_e : float
        Full-well capacity in electrons, in [100, 1e6].
    shot_noise : bool
        Photon shot noise (Poisson, normal approximation: variance = signal in e-).
    read_noise_e : float
        Read noise standard deviation in electrons, in [0, 1000]; 0 turns it off.
    vignetting : bool
        cos^4 fall-off of the field angle.
    motion_blur : bool
        Per-row vertical blur from forward motion during the exposure.
    jpeg_quality : int or None
        JPEG quality in [1, 100], or None for no compression.
    """

    exposure_time_s: float = 0.005
    auto_exposure: bool = True
    ae_target_mean: float = 0.18
    ae_rate: float = 0.25
    ev_min: float = -4.0
    ev_max: float = 4.0
    tone_shoulder: float = 1.0
    gamma: float = 1.0
    full_well_e: float = 10_000.0
    shot_noise: bool = True
    read_noise_e: float = 3.0
    vignetting: bool = True
    motion_blur: bool = True
    jpeg_quality: int | None = None

    def __post_init__(self) -> None:
        ranges = {
            "exposure_time_s": (0.0, 0.1, "s", False),
            "ae_target_mean": (0.0, 1.0, "", False),
            "ae_rate": (0.0, 1.0, "", False),
            "ev_min": (-10.0, 0.0, "EV", True),
            "ev_max": (0.0, 10.0, "EV", True),
            "tone_shoulder": (0.0, 20.0, "", True),
            "gamma": (0.2, 5.0, "", True),
            "full_well_e": (100.0, 1e6, "e-", True),
            "read_noise_e": (0.0, 1000.0, "e-", True),
        }
        for name, (low, high, unit, low_inc) in ranges.items():
            high_inc = name not in ("ae_target_mean",)
            value = check_in_range(
                name, getattr(self, name), low, high, unit=unit, low_inclusive=low_inc, high_inclusive=high_inc
            )
            object.__setattr__(self, name, value)
        for name in ("auto_exposure", "shot_noise", "vignetting", "motion_blur"):
            object.__setattr__(self, name, check_bool(name, getattr(self, name)))
        if self.jpeg_quality is not None:
            object.__setattr__(self, "jpeg_quality", check_int_in_range("jpeg_quality", self.jpeg_quality, 1, 100))

    @classmethod
    def none(cls) -> SensorParams:
        """Every effect off: the sensor returns the frame unchanged."""
        return cls(
            auto_exposure=False,
            tone_shoulder=0.0,
            gamma=1.0,
            shot_noise=False,
            read_noise_e=0.0,
            vignetting=False,
            motion_blur=False,
            jpeg_quality=None,
        )

    @property
    def is_identity(self) -> bool:
        """True when no effect is on (the frame passes unchanged)."""
        return dataclasses.replace(self, exposure_time_s=SensorParams.none().exposure_time_s) == SensorParams.none()


# ------------------------------------------------------------------ pure maths
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


@functools.lru_cache(maxsize=8)
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


def auto_exposure_update(ev: float, measured_mean: float, params: SensorParams) -> float:
    """Next frame's exposure (EV): move ``ae_rate`` of the log2 error towards the target.

    ``ev' = clip(ev + rate * log2(target / measured), ev_min, ev_max)``, so without
    saturation the log2 error shrinks by ``1 - rate`` per frame.
    """
    if not params.auto_exposure:
        return ev
    measured = max(float(measured_mean), 1e-6)
    step = params.ae_rate * math.log2(params.ae_target_mean / measured)
    return float(np.clip(ev + step, params.ev_min, params.ev_max))


def jpeg_roundtrip(rgb: np.ndarray, quality: int) -> np.ndarray:
    """Encode and decode an RGB uint8 frame as JPEG at ``quality`` (1..100)."""
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
    if decoded is None:
        raise SimroadError("jpeg_quality: OpenCV could not encode and decode the frame as JPEG.")
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)


def apply_sensor(
    rgb: np.ndarray,
    params: SensorParams,
    camera: PinholeCamera,
    rng: np.random.Generator,
    *,
    ev: float = 0.0,
    speed_m_s: float = 0.0,
    depth: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """One frame through the sensor.

    Parameters
    ----------
    rgb : ndarray, uint8, (H, W, 3)
        The rendered, weathered sRGB frame (not modified).
    params : SensorParams
    camera : PinholeCamera
        Gives the focal length, principal point, horizon and mounting height.
    rng : numpy.random.Generator
        Source of the shot and read noise.
    ev : float
        Current exposure in stops relative to ``params.exposure_time_s``.
    speed_m_s : float
        Ego forward speed in m/s.
    depth : ndarray, float32, (H, W), optional
        Ground distance per pixel in metres (the renderer's depth map).

    Returns
    -------
    rgb : ndarray, uint8, (H, W, 3)
    measured_mean : float
        Mean exposed linear signal (fraction of full well, before noise), what the
        auto-exposure meters.
    """
    if params.is_identity:
        return rgb.copy(), float(srgb_to_linear(rgb).mean())
    lin = srgb_to_linear(rgb)
    h, w = lin.shape[:2]
    fx, cx, cy = float(camera.K[0, 0]), float(camera.K[0, 2]), float(camera.K[1, 2])
    gain = 2.0**ev
    if params.motion_blur:
        lengths = motion_blur_lengths(
            h,
            focal_px=fx,
            mount_height_m=camera.config.mount_height_m,
            horizon_row=camera.horizon_row,
            speed_m_s=speed_m_s,
            exposure_s=params.exposure_time_s * gain,
            depth=depth,
        )
        lin = vertical_motion_blur(lin, lengths)
    if params.vignetting:
        lin = lin * vignetting_gain(h, w, fx, cx, cy)[:, :, None]
    exposed = np.minimum(lin * np.float32(gain), np.float32(1.0))
    measured = float(exposed.mean())
    electrons = shot_read_noise(
        exposed * np.float32(params.full_well_e), rng, shot=params.shot_noise, read_noise_e=params.read_noise_e
    )
    y = response_curve(electrons / np.float32(params.full_well_e), shoulder=params.tone_shoulder, gamma=params.gamma)
    out = linear_to_srgb(np.ascontiguousarray(y, dtype=np.float32))
    if params.jpeg_quality is not None:
        out = jpeg_roundtrip(out, params.jpeg_quality)
    return out, measured


class Sensor:
    """The stateful camera sensor of one episode: auto-exposure and noise generator.

    Parameters
    ----------
    params : SensorParams
    camera : PinholeCamera

    Attributes
    ----------
    ev : float
        Current exposure in stops relative to the nominal exposure (0 after reset).
    """

    def __init__(self, params: SensorParams, camera: PinholeCamera) -> None:
        if not isinstance(params, SensorParams):
            raise SimroadError(f"params: expected a SensorParams, got {type(params).__name__}.")
        self.params = params
        self.camera = camera
        self.ev = 0.0
        self._rng: np.random.Generator | None = None

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: exposure back to nominal, noise drawn from ``rng``."""
        if not isinstance(rng, np.random.Generator):
            raise SimroadError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}.")
        self._rng = rng
        self.ev = 0.0

    def apply(self, rgb: np.ndarray, *, speed_m_s: float = 0.0, depth: np.ndarray | None = None) -> np.ndarray:
        """Expose one frame (uint8 RGB, H x W x 3) and adapt the exposure for the next."""
        if self._rng is None:
            raise SimroadError("Sensor.apply() called before reset(); call sensor.reset(rng) first.")
        out, measured = apply_sensor(
            rgb, self.params, self.camera, self._rng, ev=self.ev, speed_m_s=speed_m_s, depth=depth
        )
        self.ev = auto_exposure_update(self.ev, measured, self.params)
        return out
