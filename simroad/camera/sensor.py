"""The camera sensor: the last stage of the camera, after the weather acts on scene radiance.

The rendered (and weathered) sRGB frame is decoded to linear scene radiance, then
goes through what a real automotive camera does to it, in physical order:

1. motion blur from the ego's forward speed during the exposure, along the radial
   flow out of the focus of expansion, its length from the depth map;
2. vignetting, cos^n of the field angle (n = 2 by default: a lens that partly
   compensates the cos^4 law);
3. exposure (nominal exposure time times the auto-exposure gain ``2**ev``) into
   electrons, photon shot noise and read noise (EMVA 1288's linear model), and the
   ADC (``adc_bits``, saturating at the full-well capacity);
4. the camera response curve (a highlight shoulder and a gamma) and the encoding,
   one table lookup from the digital number to the 8-bit output;
5. the chroma stage: chroma noise reduction and the saturation of the processing;
6. optionally JPEG compression.

The maths are pure functions (:mod:`simroad.camera._sensor_ops`); :class:`Sensor`
holds the auto-exposure state, the generator and the pre-drawn noise field of one
episode. ``SensorParams.none()`` is the identity.
"""

from __future__ import annotations

import dataclasses
import functools

import cv2
import numpy as np

from simroad.camera._blur_kernel import decode, face_share, radial_blur_depth, radial_blur_frame
from simroad.camera._sensor_kernel import expose_frame
from simroad.camera._sensor_ops import (
    NoiseTile,
    adc_response_lut,
    gain_row_buffers,
    inv_cos_bearing,
    jpeg_roundtrip,
    near_edge_maps,
    ones_map,
    vignetting_map,
)
from simroad.camera.exposure import (
    SENSOR_DECODE,
    ChromaScratch,
    auto_exposure_update,
    metered_mean,
    process_chroma,
    white_balance_gains,
)
from simroad.camera.geometry import PinholeCamera
from simroad.camera.sensor_params import SensorParams
from simroad.core.radiometry import GAMMA, srgb_to_linear
from simroad.core.validation import normalize_rng
from simroad.errors import InvalidParameterError

__all__ = ["Sensor", "apply_sensor", "exposure_travel_m", "settle_exposure"]


def settle_exposure(
    rgb: np.ndarray,
    params: SensorParams,
    camera: PinholeCamera,
    white_balance: np.ndarray | None = None,
    *,
    target: float | None = None,
) -> float:
    """The exposure (EV) at which ``rgb``'s metered mean meets ``target`` (the
    params' ``ae_target_mean`` when None): bisection
    over ``[ev_min, ev_max]`` (the mean only grows with the exposure) on a still,
    noiseless exposure, to 1/256 of the range (what a camera does before it streams)."""
    quiet = dataclasses.replace(params, shot_noise=False, read_noise_e=0.0, motion_blur=False, jpeg_quality=None)
    goal = params.ae_target_mean if target is None else float(target)
    lo, hi = params.ev_min, params.ev_max
    for _ in range(8):
        mid = 0.5 * (lo + hi)
        _, measured = apply_sensor(rgb, quiet, camera, _NO_DRAWS, ev=mid, white_balance=white_balance)
        lo, hi = (mid, hi) if measured < goal else (lo, mid)
    return 0.5 * (lo + hi)


def exposure_travel_m(params: SensorParams, speed_m_s: float, ev: float) -> float:
    """Distance (m) a camera moving at ``speed_m_s`` covers during an exposure at ``ev``
    (0 without motion blur): what the renderer blurs the ground by."""
    if not params.motion_blur:
        return 0.0
    return abs(float(speed_m_s)) * params.exposure_time_s * 2.0**ev


def apply_sensor(
    rgb: np.ndarray,
    params: SensorParams,
    camera: PinholeCamera,
    rng: np.random.Generator | int,
    *,
    ev: float = 0.0,
    speed_m_s: float = 0.0,
    depth: np.ndarray | None = None,
    noise: NoiseTile | None = None,
    white_balance: np.ndarray | None = None,
    work: np.ndarray | None = None,
    face_id: np.ndarray | None = None,
    chroma_work: ChromaScratch | None = None,
) -> tuple[np.ndarray, float]:
    """One frame through the sensor.

    Parameters
    ----------
    rgb : ndarray, uint8, (H, W, 3)
        The rendered, weathered sRGB frame (not modified).
    params : SensorParams
    camera : PinholeCamera
        Gives the focal length, principal point, horizon (focus of expansion).
    rng : numpy.random.Generator
        Source of the noise (the window of ``noise``, or a fresh field without it).
    ev : float
        Current exposure in stops relative to ``params.exposure_time_s``.
    speed_m_s : float
        Ego forward speed in m/s (its magnitude is used).
    depth : ndarray, float32, (H, W), optional
        Horizontal distance per pixel in metres (the renderer's depth map); the flat
        ground's (``camera.depth``) when None.
    noise : NoiseTile, optional
        Pre-drawn normal field of this frame size (:class:`Sensor` keeps one per
        episode); without it the frame's normals are drawn from ``rng``.
    white_balance : ndarray (3,), optional
        The episode's white-balance gains (R, G, B), applied to the exposed signal;
        neutral when None.
    work : ndarray, float32, (H, W, 3), optional
        Scratch for the motion blur's linear frame (:class:`Sensor` keeps one per
        episode; a fresh array when None). Its contents are overwritten.
    face_id : ndarray, int32, (H, W), optional
        The renderer's ``Frame.face_id``: it has blurred the ground (-1) in the
        world's texture (``Frame.motion_m``), so the sensor smears only the faces
        (>= 0), and on a face only the pixels whose blur reaches another face or the
        ground (faces are flat-coloured). None: every pixel is blurred.
    chroma_work : ChromaScratch, optional
        Scratch for the chroma stage (:class:`Sensor` keeps one per episode; fresh
        planes when None).

    Returns
    -------
    rgb : ndarray, uint8, (H, W, 3)
    measured_mean : float
        Mean of the encoded output (0-1) over the metering window, before JPEG: what
        the auto-exposure meters.
    """
    rng = normalize_rng(rng)
    if params.is_identity:
        return rgb.copy(), float(cv2.mean(srgb_to_linear(rgb))[0])
    h, w = rgb.shape[:2]
    fx, cx, cy = float(camera.K[0, 0]), float(camera.K[0, 2]), float(camera.K[1, 2])
    gain = 2.0**ev
    frame = np.ascontiguousarray(rgb)
    blurred: tuple[np.ndarray, np.ndarray] = _NOT_BLURRED
    if params.motion_blur:
        travel = exposure_travel_m(params, speed_m_s, ev)
        if travel > 0.0:
            d = np.ascontiguousarray(camera.depth if depth is None else depth, np.float32)
            lin = work if work is not None and work.shape == rgb.shape else np.empty(rgb.shape, np.float32)
            foe, inv_cos = float(camera.horizon_row), inv_cos_bearing(w, fx, cx)
            if face_id is None:  # every pixel blurred: the whole frame is linear
                decode(frame, SENSOR_DECODE, lin)
                radial_blur_depth(lin, d, _all_pixels(h, w), False, inv_cos, travel, cx, foe, MOTION_BLUR_STEP_PX)
                frame = lin
            else:
                ids = np.asarray(face_id)
                if ids.shape != (h, w) or ids.dtype != np.int32:
                    raise InvalidParameterError(
                        f"face_id: expected an int32 array of the frame's shape {(h, w)}, got {ids.dtype} {ids.shape}."
                    )
                ids = np.ascontiguousarray(ids)
                near = near_edge_maps(ids) if face_share(ids) >= NEAR_MAPS_FROM_SHARE else _NO_NEAR
                rows = radial_blur_frame(
                    frame, SENSOR_DECODE, lin, d, ids, near, inv_cos, travel, cx, foe, MOTION_BLUR_STEP_PX
                )
                blurred = (lin, rows)
    full = float(2**params.adc_bits - 1)
    wb = _NEUTRAL if white_balance is None else np.asarray(white_balance, np.float32).reshape(3)
    exponent = params.vignetting_exponent if params.vignetting else None
    vig = vignetting_map(h, w, fx, cx, cy, exponent) if exponent is not None else ones_map(h, w)
    k = full / params.full_well_e
    field, oy, ox, sign = _NO_NOISE, 0, 0, 1.0
    if params.shot_noise or params.read_noise_e > 0.0:
        if noise is not None:
            field = noise.field
            oy, ox, sign = noise.offsets(rng)
        else:
            field = np.asarray(rng.standard_normal((h, w, 3), dtype=np.float32))
    else:
        k = 0.0
    out = np.empty((h, w, 3), np.uint8)
    top = min(int(params.ae_roi_top * h), h - 1)  # the metering window: rows top .. h-1
    expose_frame(
        frame,
        SENSOR_DECODE,
        vig,
        wb,
        (gain * full, full),
        field,
        (oy, ox, sign, k if params.shot_noise else 0.0, (k * params.read_noise_e) ** 2),
        adc_response_lut(params.adc_bits, params.tone_shoulder, params.gamma),
        out,
        h,  # no row metered in the kernel: the encoded output is
        blurred,
        *gain_row_buffers(w),
    )
    measured = metered_mean(out, top)
    if params.saturation != 1.0 or params.chroma_denoise_px > 0.0:
        process_chroma(out, params.saturation, params.chroma_denoise_px, scratch=chroma_work)
    if params.jpeg_quality is not None:
        out = jpeg_roundtrip(out, params.jpeg_quality)
    return out, measured


_NO_NOISE = np.zeros((1, 1, 3), np.float32)
#: The settling exposures draw nothing (no noise): a generator that is never used.
_NO_DRAWS = np.random.default_rng(0)
#: The motion blur's plan takes near-edge maps (:func:`near_edge_maps`) from this
#: share of face pixels in the frame on: a town's facades (~0.45) gain 40 % by
#: them, roads with traffic and trees (0.03-0.16) lose by building them. The same
#: plan either way.
NEAR_MAPS_FROM_SHARE = 0.3
_NO_NEAR = (np.zeros((0, 0), np.uint8), np.zeros((0, 0), np.uint8))
#: Largest spacing of the motion blur's taps in pixels.
MOTION_BLUR_STEP_PX = 1.5


@functools.lru_cache(maxsize=8)
def _all_pixels(h: int, w: int) -> np.ndarray:
    """Every pixel an object of its own face: the whole frame is blurred."""
    ids = np.arange(h * w, dtype=np.int32).reshape(h, w)
    ids.flags.writeable = False
    return ids


_NEUTRAL = np.ones(3, np.float32)
#: No motion blur: ``expose_frame``'s ``blurred`` replaces no row.
_NOT_BLURRED = (np.zeros((1, 1, 3), np.float32), np.zeros(1, np.bool_))


class Sensor:
    """The stateful camera sensor of one episode: auto-exposure, generator, noise field.

    Parameters
    ----------
    params : SensorParams
    camera : PinholeCamera

    Attributes
    ----------
    ev : float
        Current exposure in stops relative to the nominal exposure. After ``reset``
        the first frame is metered and exposed at the target (a camera settles its
        exposure before it streams); from then on the exposure follows with one frame
        of latency at ``ae_rate``.
    """

    def __init__(self, params: SensorParams, camera: PinholeCamera) -> None:
        if not isinstance(params, SensorParams):
            raise InvalidParameterError(f"params: expected a SensorParams, got {type(params).__name__}.")
        self.params = params
        self.camera = camera
        self.ev = 0.0
        self._rng: np.random.Generator | None = None
        self._settled = False
        self._noise: NoiseTile | None = None
        self.target = params.ae_target_mean
        self.white_balance: np.ndarray | None = None
        self._work: np.ndarray | None = None
        self._chroma: ChromaScratch | None = None

    def reset(self, rng: np.random.Generator | int, *, illuminant_k: float = 6504.0) -> None:
        """Start an episode: exposure back to nominal, noise field drawn from ``rng``,
        the white balance for a scene lit by daylight of ``illuminant_k`` kelvin (the
        world's :attr:`~simroad.camera.sky.SkySpec.illuminant_k`)."""
        self._rng = rng = normalize_rng(rng)
        self.ev = 0.0
        self._settled = not self.params.auto_exposure
        p, c = self.params, self.camera.config
        self._noise = NoiseTile(c.height, c.width, rng) if (p.shot_noise or p.read_noise_e > 0.0) else None
        self._work = np.empty((c.height, c.width, 3), np.float32) if p.motion_blur else None
        self._chroma = ChromaScratch(c.height, c.width)
        # Drawn after the noise field (that stream is unchanged): the AWB's error, along
        # the daylight locus (in mired) and across it (a green or magenta tint).
        locus, tint = rng.normal(0.0, 1.0, 2) if (p.wb_error_mired > 0.0 or p.white_balance_error > 0.0) else (0, 0)
        self.white_balance = white_balance_gains(
            p, illuminant_k, error_mired=p.wb_error_mired * locus, error_tint=p.white_balance_error * tint
        )
        self.target = p.ae_target_mean
        if p.ae_scene_bias_ev > 0.0:  # the meter's scene-dependent bias, drawn last
            bias = float(rng.normal(0.0, p.ae_scene_bias_ev))
            self.target = min(0.95, max(0.05, p.ae_target_mean * 2.0 ** (bias / GAMMA)))

    def travel_m(self, speed_m_s: float) -> float:
        """Distance (m) the camera covers during the next frame's exposure at
        ``speed_m_s``: what the renderer blurs the ground by (0 without motion blur)."""
        # Before the first frame the exposure is not settled yet: the nominal one.
        return exposure_travel_m(self.params, speed_m_s, self.ev)

    def apply(
        self,
        rgb: np.ndarray,
        *,
        speed_m_s: float = 0.0,
        depth: np.ndarray | None = None,
        face_id: np.ndarray | None = None,
    ) -> np.ndarray:
        """Expose one frame (uint8 RGB, H x W x 3) and adapt the exposure for the next.

        ``face_id`` (the renderer's ``Frame.face_id``) leaves the ground's motion blur
        to the renderer (see :func:`apply_sensor`)."""
        if self._rng is None:
            raise InvalidParameterError("Sensor.apply() called before reset(); call sensor.reset(rng) first.")
        if not self._settled:
            # A camera settles its exposure before it streams: the first frame is
            # exposed at the target.
            self.ev = settle_exposure(rgb, self.params, self.camera, self.white_balance, target=self.target)
            self._settled = True
        noise = (
            self._noise
            if self._noise is not None and rgb.shape[:2] == (self._noise.height, self._noise.width)
            else None
        )
        out, measured = apply_sensor(
            rgb,
            self.params,
            self.camera,
            self._rng,
            ev=self.ev,
            speed_m_s=speed_m_s,
            depth=depth,
            noise=noise,
            white_balance=self.white_balance,
            work=self._work,
            face_id=face_id,
            chroma_work=self._chroma,
        )
        self.ev = auto_exposure_update(self.ev, measured, self.params, target=self.target)
        return out
