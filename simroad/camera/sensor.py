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

import numpy as np

from simroad._validation import SimroadError, check_bool, check_in_range, check_int_in_range
from simroad.camera._sensor_ops import (
    jpeg_roundtrip,
    motion_blur_lengths,
    response_curve,
    shot_read_noise,
    vertical_motion_blur,
    vignetting_gain,
)
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


@functools.lru_cache(maxsize=8)
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
