"""The camera sensor's physical parameters (docs/camera.md): :class:`SensorParams`.

Its defaults for the response curve, the white balance, the full well and the
meter's scene bias are the default camera profile's (:mod:`simroad.camera.profile`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from simroad.camera.profile import CameraProfile
from simroad.core.daylight import CCT_RANGE_K
from simroad.core.radiometry import GAMMA
from simroad.core.validation import check_bool, check_fields_in_range, check_int_in_range

__all__ = ["SensorParams"]


#: simroad's default camera profile: the sensor's defaults are its camera values.
_PROFILE = CameraProfile()


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
        Target mean of the encoded output over the metering window (0-1 of the 8-bit
        range), in (0, 1). Camera ISPs collect their auto-exposure statistics on
        the processed (gamma-encoded) image and drive its mean luma to a fixed level,
        about 0.4 (Battiato et al. 2009, "Exposure correction for imaging devices",
        in Single-Sensor Imaging, CRC; ON Semiconductor AR0231 ISP AE documentation):
        a bright sky then counts at most as white and saturates, instead of
        darkening the whole frame until it does not.
    ae_scene_bias_ev : float
        Standard deviation (EV) of the meter's per-episode bias, in [0, 2]: matrix and
        centre-weighted meters put scenes of the same mean at exposures a third to
        half a stop apart (what they weigh differs from scene to scene); drawn once
        per episode, 0 meters every scene alike.
    ae_rate : float
        Fraction of the log2 exposure error corrected per frame, in (0, 1].
    ae_roi_top : float
        Top of the metering window as a fraction of the image height, in [0, 1): the
        auto-exposure meters the rows from there to the bottom; 0 (default) meters
        the whole frame, sky included, as dash cameras do.
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
    adc_bits : int
        ADC resolution in bits, in [8, 16]; full scale is the full well.
    shot_noise : bool
        Photon shot noise (Poisson, normal approximation: variance = signal in e-).
    read_noise_e : float
        Read noise standard deviation in electrons, in [0, 1000]; 0 turns it off.
    wb_preset_k : float
        The colour temperature (K) the camera's white balance starts from, its
        daylight preset, in [4000, 10000].
    awb_strength : float
        Share of the way, in mired, the auto white balance moves from the preset to
        the scene's light, in [0, 1]: 1 is a perfect grey-world correction, 0 a fixed
        preset. Cameras correct partly, so a scene lit by colder light than the preset
        (an overcast or blue sky) comes out cool and warmer light warm.
    wb_error_mired : float
        Standard deviation of the auto white balance's error along the daylight
        locus, in mired, in [0, 200]: per episode the camera balances for a colour
        temperature that far (``N(0, error)`` mired) from the one it aims at, bluer
        or yellower. AWB estimates err mostly along the locus, by 10-30 mired on
        real scenes (Finlayson, Hordley & Hubel 2001; Gijsenij, Gevers & van de
        Weijer 2011, IEEE TIP 20:2475, median angular errors of 2-6 degrees).
    white_balance_error : float
        Standard deviation of the error across the locus, in [0, 0.5]: green against
        red and blue, a log-gain ``N(0, error)`` per episode (a green or magenta
        tint, smaller than the error along the locus).
    vignetting : bool
        cos^n fall-off of the field angle.
    saturation : float
        Chroma gain of the processing after the gamma, in [0, 3]: 1 is colorimetric,
        cameras render 1.1-1.4 (:func:`simroad.camera.exposure.saturate`).
    chroma_denoise_px : float
        Standard deviation (pixels, in [0, 10]) of the Gaussian the processing
        smooths the chroma with (chroma noise reduction and 4:2:0 video), 0 for none
        (:func:`simroad.camera.exposure.process_chroma`).
    vignetting_exponent : float
        ``n``, in [0, 8]: 4 is a thin lens's natural vignetting (the cos^4 law); the
        default 2 models a lens that partly compensates it, as automotive lenses do
        (relative illumination ~60-80 % at the corner).
    motion_blur : bool
        Radial blur from forward motion during the exposure (length from the depth map).
    jpeg_quality : int or None
        JPEG quality in [1, 100], or None for no compression.
    """

    exposure_time_s: float = 0.005
    auto_exposure: bool = True
    ae_target_mean: float = 0.36
    ae_scene_bias_ev: float = _PROFILE.exposure_spread_ev
    ae_rate: float = 0.25
    ae_roi_top: float = 0.0
    ev_min: float = -4.0
    ev_max: float = 4.0
    tone_shoulder: float = _PROFILE.tone_shoulder
    gamma: float = _PROFILE.tone_gamma
    full_well_e: float = _PROFILE.full_well_e
    adc_bits: int = 12
    shot_noise: bool = True
    read_noise_e: float = 3.0
    wb_preset_k: float = _PROFILE.wb_preset_k
    awb_strength: float = _PROFILE.awb_strength
    wb_error_mired: float = 15.0
    white_balance_error: float = 0.02
    saturation: float = _PROFILE.saturation
    chroma_denoise_px: float = 1.5
    vignetting: bool = True
    vignetting_exponent: float = 2.0
    motion_blur: bool = True
    jpeg_quality: int | None = None

    def __post_init__(self) -> None:
        ranges = {
            "exposure_time_s": (0.0, 0.1, "s", False),
            "ae_target_mean": (0.0, 1.0, "", False),
            "ae_rate": (0.0, 1.0, "", False),
            "ae_scene_bias_ev": (0.0, 2.0, "EV", True),
            "ae_roi_top": (0.0, 1.0, "", True),
            "ev_min": (-10.0, 0.0, "EV", True),
            "ev_max": (0.0, 10.0, "EV", True),
            "tone_shoulder": (0.0, 20.0, "", True),
            "gamma": (0.2, 5.0, "", True),
            "full_well_e": (100.0, 1e6, "e-", True),
            "read_noise_e": (0.0, 1000.0, "e-", True),
            "wb_preset_k": (CCT_RANGE_K[0], 10000.0, "K", True),
            "awb_strength": (0.0, 1.0, "", True),
            "wb_error_mired": (0.0, 200.0, "mired", True),
            "white_balance_error": (0.0, 0.5, "", True),
            "vignetting_exponent": (0.0, 8.0, "", True),
            "saturation": (0.0, 3.0, "", True),
            "chroma_denoise_px": (0.0, 10.0, "px", True),
        }
        for name, value in check_fields_in_range(self, ranges, high_exclusive=("ae_target_mean", "ae_roi_top")).items():
            object.__setattr__(self, name, value)
        for name in ("auto_exposure", "shot_noise", "vignetting", "motion_blur"):
            object.__setattr__(self, name, check_bool(name, getattr(self, name)))
        object.__setattr__(self, "adc_bits", check_int_in_range("adc_bits", self.adc_bits, 8, 16))
        if self.jpeg_quality is not None:
            object.__setattr__(self, "jpeg_quality", check_int_in_range("jpeg_quality", self.jpeg_quality, 1, 100))

    @classmethod
    def none(cls) -> SensorParams:
        """Every effect off: the sensor returns the frame unchanged."""
        return cls(
            auto_exposure=False,
            ae_scene_bias_ev=0.0,
            saturation=1.0,
            chroma_denoise_px=0.0,
            tone_shoulder=0.0,
            gamma=1.0,
            shot_noise=False,
            read_noise_e=0.0,
            awb_strength=1.0,
            wb_error_mired=0.0,
            white_balance_error=0.0,
            vignetting=False,
            motion_blur=False,
            jpeg_quality=None,
        )

    def with_profile(self, profile: CameraProfile) -> SensorParams:
        """These parameters with the camera fields (:data:`~simroad.camera.profile.CAMERA_FIELDS`)
        of ``profile``: its exposure bias moves the auto-exposure's target (through the
        encoding, at most 0.95), the rest are the sensor's fields of the same meaning."""
        return dataclasses.replace(
            self,
            ae_target_mean=min(0.95, self.ae_target_mean * 2.0 ** (profile.exposure_bias_ev / GAMMA)),
            ae_scene_bias_ev=profile.exposure_spread_ev,
            wb_preset_k=profile.wb_preset_k,
            awb_strength=profile.awb_strength,
            gamma=profile.tone_gamma,
            tone_shoulder=profile.tone_shoulder,
            saturation=profile.saturation,
            full_well_e=profile.full_well_e,
        )

    @property
    def is_identity(self) -> bool:
        """True when no effect is on (the frame passes unchanged)."""
        effects = (self.auto_exposure, self.shot_noise, self.vignetting, self.motion_blur)  # the bias acts via the AE
        return (
            not any(effects)
            and self.read_noise_e == 0.0
            and self.white_balance_error == 0.0
            and self.wb_error_mired == 0.0
            and self.awb_strength == 1.0
            and self.tone_shoulder == 0.0
            and self.gamma == 1.0
            and self.jpeg_quality is None
            and self.saturation == 1.0
            and self.chroma_denoise_px == 0.0
        )
