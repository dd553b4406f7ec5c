"""The sky: luminance from the CIE standard general sky, colour from the sun and the weather.

Luminance follows the CIE standard general sky (ISO 15469:2004 / CIE S 011/E:2003):
relative to the zenith,

``L(Z, chi) / L_z = f(chi) phi(Z) / (f(Z_s) phi(0))``

with the gradation ``phi(Z) = 1 + a exp(b / cos Z)`` (``phi(90 deg) = 1``) and the
indicatrix ``f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi``, where ``Z``
is a direction's zenith angle, ``Z_s`` the sun's and ``chi`` the angle between the
direction and the sun. :data:`CIE_SKY_TYPES` holds the 15 standard (a, b, c, d, e);
a ``condition`` picks types: ``overcast`` 1 and 3, ``hazy`` 7-9, ``clear`` 12-13.

Scaling (the units of :mod:`simroad.camera.lighting`): a perfect white horizontal
surface has linear value ``NOMINAL_EXPOSURE``. Its radiance is ``E_h / pi`` with
``E_h`` the global horizontal irradiance = diffuse sky irradiance ``D`` (the cosine-
weighted integral of the sky over the hemisphere) plus the direct sun. The diffuse
fraction ``D / E_h`` is 1 for overcast, about 0.7 for hazy (a veiled sun) and 0.15-0.25 for clear
skies (depending on the sun's elevation), so the sky radiance is
``L = NOMINAL_EXPOSURE * pi * (D / E_h) * L_rel / D_rel``. For the CIE overcast sky
(type 1, Moon & Spencer) ``D_rel = 7 pi / 9``: the zenith is 9/7 of the white
surface (it saturates) and the horizon 3/7 of it (light grey).

Colour: overcast is neutral grey-white; a clear sky is blue at the zenith and away
from the sun and whitens towards the horizon (longer air path, Kasten & Young air
mass) and in the sun's aureole; a hazy sky is a paler blue.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simroad.camera.geometry import PinholeCamera
from simroad.camera.lighting import NOMINAL_EXPOSURE
from simroad.camera.profile import CameraProfile
from simroad.core.daylight import CCT_RANGE_K
from simroad.core.radiometry import linear_to_srgb
from simroad.core.validation import check_choice, check_in_range, normalize_rng
from simroad.errors import InvalidParameterError

__all__ = [
    "CIE_SKY_TYPES",
    "CONDITIONS",
    "SKY_VIEW",
    "SkySpec",
    "Sun",
    "camera_directions",
    "cie_relative_luminance",
    "draw_sky",
    "illuminant_cct",
    "sky_image",
    "sky_radiance",
]

#: CIE standard general sky types 1-15: (a, b, c, d, e) of ISO 15469 / CIE S 011.
CIE_SKY_TYPES: dict[int, tuple[float, float, float, float, float]] = {
    1: (4.0, -0.70, 0.0, -1.0, 0.00),
    2: (4.0, -0.70, 2.0, -1.5, 0.15),
    3: (1.1, -0.80, 0.0, -1.0, 0.00),
    4: (1.1, -0.80, 2.0, -1.5, 0.15),
    5: (0.0, -1.00, 0.0, -1.0, 0.00),
    6: (0.0, -1.00, 2.0, -1.5, 0.15),
    7: (0.0, -1.00, 5.0, -2.5, 0.30),
    8: (0.0, -1.00, 10.0, -3.0, 0.45),
    9: (-1.0, -0.55, 2.0, -1.5, 0.15),
    10: (-1.0, -0.55, 5.0, -2.5, 0.30),
    11: (-1.0, -0.55, 10.0, -3.0, 0.45),
    12: (-1.0, -0.32, 10.0, -3.0, 0.45),
    13: (-1.0, -0.32, 16.0, -3.0, 0.30),
    14: (-1.0, -0.15, 16.0, -3.0, 0.30),
    15: (-1.0, -0.15, 24.0, -2.8, 0.15),
}
#: Weather conditions of the sky and the CIE types each draws from.
CONDITIONS: dict[str, tuple[int, ...]] = {"overcast": (1, 3), "hazy": (7, 8, 9), "clear": (12, 13)}
#: The ground's sky-view factor range per ground profile (see :func:`draw_sky`).
SKY_VIEW: dict[str, tuple[float, float]] = {"rural": (0.9, 1.0), "urban": (0.5, 0.8)}
_DEFAULT_TYPE = {"overcast": 1, "hazy": 8, "clear": 12}
# Linear RGB per unit luminance (Y = 1), relative to the light on the ground (frames
# are rendered as a camera balanced for that light sees them; the camera's own cast
# comes after, simroad.camera.exposure.white_balance_gains): clear-sky zenith blue
# (sRGB ~ (95, 145, 215)) and the overcast sky, which is that light: white.
_BLUE = np.array([0.33, 0.90, 2.40], dtype=np.float32)
_WHITE = np.array([1.0, 1.0, 1.0], dtype=np.float32)
_BLUENESS = {"overcast": 0.0, "hazy": 0.3, "clear": 1.0}
_TURBIDITY = {"overcast": 1.0, "hazy": 0.25, "clear": 0.10}  # whitening per extra air mass


@dataclass(frozen=True)
class Sun:
    """The sun's direction: azimuth (degrees, world frame: 0 = +x, 90 = +y) and
    elevation above the horizon (degrees, 0-90)."""

    azimuth_deg: float
    elevation_deg: float

    def __post_init__(self) -> None:
        check_in_range("sun.azimuth_deg", self.azimuth_deg, -360.0, 360.0, unit="degrees")
        check_in_range("sun.elevation_deg", self.elevation_deg, 0.0, 90.0, unit="degrees")


@dataclass(frozen=True)
class SkySpec:
    """One world's sky: the weather ``condition``, the ``sun``, a ``brightness``
    factor (cloud thickness varies: relative sky radiance) and the correlated colour
    temperature ``illuminant_k`` of the light it and the sun shed on the ground (K);
    ``sky_view`` is the ground's sky-view factor (:func:`draw_sky`), already in
    ``brightness``."""

    condition: str
    sun: Sun
    brightness: float = 1.0
    cie_type: int | None = None
    illuminant_k: float = 6504.0
    sky_view: float = 1.0

    def __post_init__(self) -> None:
        check_choice("condition", self.condition, tuple(CONDITIONS))
        check_in_range("brightness", self.brightness, 0.1, 10.0)
        check_in_range("illuminant_k", self.illuminant_k, *CCT_RANGE_K, unit="K")
        check_in_range("sky_view", self.sky_view, 0.05, 1.0)
        if self.cie_type is not None and self.cie_type not in CIE_SKY_TYPES:
            check_choice("cie_type", str(self.cie_type), [str(k) for k in CIE_SKY_TYPES])


def cie_relative_luminance(zenith: np.ndarray, chi: np.ndarray, sun_zenith: float, sky_type: int) -> np.ndarray:
    """Sky luminance relative to the zenith's, ``L / L_z`` (float64, broadcast shape).

    Parameters
    ----------
    zenith : ndarray
        Zenith angle of each direction, radians in [0, pi/2].
    chi : ndarray
        Angle between each direction and the sun, radians in [0, pi].
    sun_zenith : float
        The sun's zenith angle, radians.
    sky_type : int
        CIE standard sky type, 1-15.
    """
    a, b, c, d, e = CIE_SKY_TYPES[sky_type]
    z = np.asarray(zenith, dtype=float)
    x = np.asarray(chi, dtype=float)
    with np.errstate(divide="ignore", over="ignore"):
        cz = np.cos(np.minimum(z, math.pi / 2))
        phi = 1.0 + a * np.where(cz > 1e-9, np.exp(b / np.maximum(cz, 1e-9)), 0.0)
    f = 1.0 + c * (np.exp(d * x) - math.exp(d * math.pi / 2)) + e * np.cos(x) ** 2
    f_zen = 1.0 + c * (math.exp(d * sun_zenith) - math.exp(d * math.pi / 2)) + e * math.cos(sun_zenith) ** 2
    return phi * f / ((1.0 + a * math.exp(b)) * f_zen)


def _diffuse_integral(sun_zenith: float, sky_type: int, n: int = 90) -> float:
    """``D_rel``: the cosine-weighted hemisphere integral of ``L / L_z`` (sr)."""
    z = (np.arange(n) + 0.5) * (math.pi / 2) / n
    az = (np.arange(2 * n) + 0.5) * math.pi / n
    Z, A = np.meshgrid(z, az, indexing="ij")
    cos_chi = np.cos(Z) * math.cos(sun_zenith) + np.sin(Z) * math.sin(sun_zenith) * np.cos(A)
    L = cie_relative_luminance(Z, np.arccos(np.clip(cos_chi, -1, 1)), sun_zenith, sky_type)
    return float((L * np.cos(Z) * np.sin(Z)).sum() * (math.pi / 2 / n) * (math.pi / n))


def _diffuse_fraction(condition: str, sun_elevation_deg: float) -> float:
    if condition == "overcast":
        return 1.0
    if condition == "hazy":
        return 0.7
    return float(np.clip(0.12 + 0.25 * (1.0 - math.sin(math.radians(max(sun_elevation_deg, 5.0)))), 0.12, 0.35))


def _air_mass(zenith: np.ndarray) -> np.ndarray:
    """Kasten & Young (1989) relative optical air mass (zenith in radians)."""
    zd = np.degrees(np.minimum(zenith, math.pi / 2))
    return 1.0 / (np.cos(np.radians(zd)) + 0.50572 * (96.07995 - zd) ** -1.6364)


def sky_radiance(
    directions: np.ndarray,
    *,
    sun_azimuth: float,
    sun_elevation: float,
    condition: str,
    sky_type: int | None = None,
    brightness: float = 1.0,
) -> np.ndarray:
    """Linear RGB radiance of the sky in world directions (units of :mod:`~simroad.camera.lighting`).

    Parameters
    ----------
    directions : ndarray (..., 3)
        World directions (x, y, z up); normalised here. Directions below the horizon
        get the horizon's radiance.
    sun_azimuth, sun_elevation : float
        The sun (degrees; azimuth 0 = +x, 90 = +y).
    condition : str
        ``overcast``, ``hazy`` or ``clear``.
    sky_type : int, optional
        CIE type 1-15 (default: 1, 8 and 12 for the three conditions).
    brightness : float
        Factor on the radiance.

    Returns
    -------
    ndarray, float32, (..., 3)
    """
    check_choice("condition", condition, tuple(CONDITIONS))
    sky = SkySpec(condition, Sun(sun_azimuth, sun_elevation), brightness, sky_type)
    t = sky.cie_type or _DEFAULT_TYPE[condition]
    v = np.asarray(directions, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    vz = np.clip(v[..., 2], 0.0, 1.0)
    zen = np.arccos(vz)
    az, el = math.radians(sun_azimuth), math.radians(sun_elevation)
    s = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    horiz = np.linalg.norm(v[..., :2], axis=-1, keepdims=True)
    vv = np.concatenate([v[..., :2] / np.maximum(horiz, 1e-9) * np.sin(zen)[..., None], vz[..., None]], axis=-1)
    chi = np.arccos(np.clip(vv @ s, -1.0, 1.0))
    sun_z = math.pi / 2 - el
    rel = cie_relative_luminance(zen, chi, sun_z, t)
    scale = NOMINAL_EXPOSURE * math.pi * _diffuse_fraction(condition, sun_elevation) / _diffuse_integral(sun_z, t)
    lum = (rel * scale * brightness)[..., None]
    whiten = 1.0 - np.exp(-_TURBIDITY[condition] * (_air_mass(zen) - 1.0))
    aureole = np.exp(-((chi / math.radians(25.0)) ** 2))
    blue = _BLUENESS[condition] * (1.0 - whiten) * (1.0 - aureole)
    colour = _WHITE + blue[..., None] * (_BLUE - _WHITE)
    return (lum * colour).astype(np.float32)


def camera_directions(camera: PinholeCamera, heading: float | None = None) -> np.ndarray:
    """World direction (x, y, z up) of every pixel's ray, float64 (H, W, 3), for the
    camera's current heading or ``heading`` (radians)."""
    c = camera.config
    u, v = np.meshgrid(np.arange(c.width, dtype=float), np.arange(c.height, dtype=float))
    rays_cam = np.stack([u, v, np.ones_like(u)], axis=-1) @ camera.K_inv.T
    ego = rays_cam @ camera._R_ego  # ego frame: X forward, Y right, Z down
    h = camera.pose[2] if heading is None else float(heading)
    ch, sh = math.cos(h), math.sin(h)
    # ego right (Y) is world (-sin h, cos h) -- the world frame of highway-env (y down on screen)
    wx = ch * ego[..., 0] - sh * ego[..., 1]
    wy = sh * ego[..., 0] + ch * ego[..., 1]
    return np.stack([wx, wy, -ego[..., 2]], axis=-1)


def sky_image(
    camera: PinholeCamera,
    condition: str | SkySpec,
    sun: Sun | None = None,
    *,
    heading: float | None = None,
    brightness: float = 1.0,
) -> np.ndarray:
    """The sky as the camera sees it: float32 (H, W, 3) sRGB 0-255.

    Parameters
    ----------
    camera : PinholeCamera
    condition : str or SkySpec
        ``overcast``, ``hazy`` or ``clear`` (with ``sun``), or a whole
        :class:`SkySpec` (e.g. from :func:`draw_sky`). The shadow or glare noise may
        pass ``"clear"`` and its own sun when the sun comes out.
    sun : Sun, optional
        Required with a condition name.
    heading : float, optional
        Camera heading (radians) the sky is seen from; the camera's current pose by
        default.
    brightness : float
        Factor on the radiance (with a condition name).

    Every pixel gets a value (the ground is drawn over it); rays below the horizon
    take the horizon's radiance. Values above white saturate at 255.
    """

    if isinstance(condition, SkySpec):
        sky = condition
    else:
        if not isinstance(sun, Sun):
            raise InvalidParameterError(
                f"sun: expected a simroad.camera.sky.Sun with a condition name, got {type(sun).__name__}. "
                "Pass sun=Sun(azimuth_deg, elevation_deg) or a SkySpec."
            )
        sky = SkySpec(condition, sun, brightness)
    d = camera_directions(camera, heading)
    d[..., 2] = np.maximum(d[..., 2], 0.0)
    lin = sky_radiance(
        d,
        sun_azimuth=sky.sun.azimuth_deg,
        sun_elevation=sky.sun.elevation_deg,
        condition=sky.condition,
        sky_type=sky.cie_type,
        brightness=sky.brightness,
    )
    return linear_to_srgb(lin, np.float32) * np.float32(255.0)


def illuminant_cct(condition: str, sun_elevation_deg: float, rng: np.random.Generator) -> float:
    """The CCT (K) of the light on the ground: an overcast sky's 6300-7500 K, a hazy
    day's 5800-6800 K; under a clear sky the sun's light, about 4500 K just above the
    horizon, warming less as the sun climbs, 5500-6200 K from 30 degrees (CIE 15:2004
    daylight; Hernandez-Andres, Romero & Lee 2001, JOSA A 18:412, on measured
    daylight CCTs)."""
    if condition == "overcast":
        return float(rng.uniform(6300.0, 7500.0))
    if condition == "hazy":
        return float(rng.uniform(5800.0, 6800.0))
    high = min(1.0, max(0.0, (sun_elevation_deg - 5.0) / 25.0))
    return float(4500.0 + 1200.0 * high + rng.uniform(0.0, 500.0))


def draw_sky(
    rng: np.random.Generator | int,
    *,
    condition: str | None = None,
    daylight: CameraProfile | None = None,
    sky_view: tuple[float, float] = (1.0, 1.0),
) -> SkySpec:
    """One world's sky, from ``daylight`` (a :class:`~simroad.camera.profile.CameraProfile`;
    simroad's default when None): the condition (overcast, hazy or clear by the
    profile's shares, unless given), a CIE type of it, the sun (any azimuth, elevation
    uniform in the profile's range), a brightness factor (uniform in its range: cloud
    thickness and haze) and the light's colour temperature (:func:`illuminant_cct`).

    ``sky_view`` is the range of the ground's sky-view factor: the share of the sky
    the street sees between its buildings (1 on an open road, 0.5-0.8 in a street
    canyon of height-to-width 0.5-1, Oke 1987 ch. 8). The ground and what stands on
    it get that share of the light, so relative to them the sky is ``1 / sky_view``
    brighter."""
    from_profile = daylight if daylight is not None else CameraProfile()
    rng = normalize_rng(rng)
    u = rng.random()
    if condition is None:
        o, h = from_profile.overcast_share, from_profile.hazy_share
        cond = "overcast" if u < o else ("hazy" if u < o + h else "clear")
    else:
        cond = check_choice("condition", condition, tuple(CONDITIONS))
    types = CONDITIONS[cond]
    t = int(types[int(rng.integers(len(types)))])
    sun = Sun(float(rng.uniform(-180.0, 180.0)), float(rng.uniform(*from_profile.sun_elevation_deg)))
    view = float(rng.uniform(*sky_view))
    brightness = float(rng.uniform(*from_profile.sky_brightness)) / view
    return SkySpec(cond, sun, brightness, t, illuminant_cct(cond, sun.elevation_deg, rng), view)
