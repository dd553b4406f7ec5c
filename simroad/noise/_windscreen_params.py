"""The windscreen's parameters and its physics without state: the wiper settings, the
drops' sources and collection rate, and their slide along the glass.

:mod:`simroad.noise.windscreen` (the model, and the physics in its docstring) re-exports
the public names.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from simroad.core.validation import check_choice, check_in_range
from simroad.errors import InvalidParameterError, SimroadError
from simroad.noise._glass import Glass
from simroad.noise.model import Limit, Params
from simroad.noise.rain import D_RANGE_MM as RAIN_D_MM
from simroad.noise.rain import MP_N0, marshall_palmer_slope, terminal_velocity
from simroad.noise.snow import D_RANGE_MM as SNOW_D_MM
from simroad.noise.snow import SIZE_SLOPE_PER_MM, flake_fall_speed

__all__ = ["WIPER_MODES", "WindscreenParams", "collection_rate", "slide_velocity"]

WIPER_MODES: Mapping[str, float | str | None] = {
    "off": None,
    "intermittent": 5.0,
    "slow": 1.5,
    "fast": 1.0,
    "auto": "auto",
}
"""Named wiper settings: seconds between cycle starts, None (off) or the rain sensor."""

_WATER_KG_M3 = 1000.0


@dataclass(frozen=True)
class WindscreenParams(Params):
    """Physical parameters of the windscreen, its drops and its wiper.

    The drops' arrival rate comes from the rain and snow of the weather (see
    :class:`WindscreenModel`); these are the glass, the lens, the water and the wiper.

    Parameters
    ----------
    wiper_period_s : float, str or None
        Seconds between wipe cycles (>= two strokes), a key of :data:`WIPER_MODES`
        (``"off"``, ``"intermittent"``, ``"slow"``, ``"fast"``, ``"auto"``: a rain
        sensor), or None (off).
    wiper_stroke_s : float
        Duration of one stroke (up or down), s.
    wiper_arc_deg : float
        Angle the blade sweeps, degrees.
    wiper_pivot_m : tuple of float
        The blade's pivot in glass coordinates (right, up along the glass), m.
    wiper_length_m, wiper_width_m : float
        The blade's reach from the pivot and its visible width, m.
    sensor_coverage : float
        ``"auto"`` wipes when the drops cover this fraction of the glass in view.
    glass_distance_m : float
        Distance from the lens to the glass along the optical axis, m.
    glass_tilt_deg : float
        Tilt of the glass back from vertical, degrees (a car's windscreen: 55-65).
    focal_length_mm, f_number : float
        The lens: focal length (mm) and f-number (aperture = focal length / f-number).
    focus_m : float
        Distance the camera is focused at, m.
    contact_angle_deg : float
        Contact angle of water on the glass, degrees (clean glass 20-30, weathered
        40-70, water-repellent coating 90-110).
    max_contact_radius_mm : float
        Largest contact radius of a drop (bigger arrivals splash), mm.
    slide_radius_mm : float
        Contact radius of the smallest drop that runs down a still car's glass, mm.
    airflow_speed_m_s : float
        Car speed at which the airflow pushes that drop up as hard as gravity pulls
        it down, m/s.
    slide_speed_m_s : float
        Speed of a running drop per unit excess force (in units of gravity's pull), m/s.
    max_coverage : float
        Fraction of the glass the drops may cover (then arrivals stop).
    max_drops : int
        Most drops on the glass at once (the cost per frame grows with them).
    min_drop_px : float
        Drops whose image is narrower than this half-width (px) are not drawn.
    snow_density_kg_m3 : float
        Density of a snowflake (its melted drop has the same mass), kg/m³.
    rim_brightness : float
        What a drop's totally reflecting rim shows, as a fraction of the drop's mean
        view (an assumption: the reflected rays leave the drop along the glass).
    blade_radiance : float
        Linear radiance of the wiper blade (relative to white).

    Each field's valid range is declared once, in ``LIMITS`` (listed under Notes);
    ``wiper_period_s`` is checked against its ``wiper_stroke_s``.
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {
        "wiper_stroke_s": Limit(0.1, 3.0, "s"),
        "wiper_arc_deg": Limit(10.0, 180.0, "degrees"),
        "wiper_pivot_m": Limit(-3.0, 3.0, "m", length=2),
        "wiper_length_m": Limit(0.05, 3.0, "m"),
        "wiper_width_m": Limit(0.001, 0.2, "m"),
        "sensor_coverage": Limit(0.0, 1.0, low_inclusive=False),
        "glass_distance_m": Limit(0.02, 1.5, "m"),
        "glass_tilt_deg": Limit(0.0, 75.0, "degrees"),
        "focal_length_mm": Limit(1.0, 50.0, "mm"),
        "f_number": Limit(0.95, 32.0),
        "focus_m": Limit(1.0, 1e6, "m"),
        "contact_angle_deg": Limit(10.0, 150.0, "degrees"),
        "max_contact_radius_mm": Limit(0.1, 10.0, "mm"),
        "slide_radius_mm": Limit(0.1, 10.0, "mm"),
        "airflow_speed_m_s": Limit(1.0, 100.0, "m/s"),
        "slide_speed_m_s": Limit(0.0, 1.0, "m/s"),
        "max_coverage": Limit(0.0, 1.0),
        "max_drops": Limit(0, 20000, integer=True),
        "min_drop_px": Limit(0.0, 10.0, "px"),
        "snow_density_kg_m3": Limit(10.0, 1000.0, "kg/m^3"),
        "rim_brightness": Limit(0.0, 1.0),
        "blade_radiance": Limit(0.0, 1.0),
    }

    wiper_period_s: float | str | None = "auto"
    wiper_stroke_s: float = 0.5
    wiper_arc_deg: float = 110.0
    wiper_pivot_m: tuple[float, float] = (-0.2, -0.55)
    wiper_length_m: float = 0.75
    wiper_width_m: float = 0.02
    sensor_coverage: float = 0.05
    glass_distance_m: float = 0.1
    glass_tilt_deg: float = 55.0
    focal_length_mm: float = 4.0
    f_number: float = 2.0
    focus_m: float = 10.0
    contact_angle_deg: float = 50.0
    max_contact_radius_mm: float = 2.5
    slide_radius_mm: float = 2.0
    airflow_speed_m_s: float = 25.0
    slide_speed_m_s: float = 0.05
    max_coverage: float = 0.35
    max_drops: int = 2000
    min_drop_px: float = 0.3
    snow_density_kg_m3: float = 100.0
    rim_brightness: float = 0.3
    blade_radiance: float = 0.03

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "wiper_period_s", _check_period(self.wiper_period_s, self.wiper_stroke_s))

    @classmethod
    def from_severity(cls, severity: float) -> WindscreenParams:
        """The defaults: the severity acts through the rain's and snow's rates."""
        check_in_range("severity", severity, 0.0, 1.0)
        return cls()

    @property
    def is_identity(self) -> bool:
        return False  # the weather's rain and snow decide (WindscreenModel.is_identity)

    @property
    def glass(self) -> Glass:
        """The glass and lens as :class:`~simroad.noise._glass.Glass` (SI units)."""
        f = self.focal_length_mm * 1e-3
        return Glass(self.glass_distance_m, self.glass_tilt_deg, f, f / self.f_number, self.focus_m)


def _check_period(value: Any, stroke_s: float) -> float | str | None:
    """A wiper period: None, a mode name, or seconds in [2·stroke, 120]."""
    if value is None:
        return None
    if isinstance(value, str):
        mode = WIPER_MODES[check_choice("wiper_period_s", value, tuple(WIPER_MODES))]
        return mode if not isinstance(mode, float) else _check_period(mode, stroke_s)
    low = 2.0 * stroke_s
    try:
        return check_in_range("wiper_period_s", value, low, 120.0, unit="s")
    except SimroadError as exc:
        raise InvalidParameterError(
            f"{exc} A wipe cycle is two strokes of wiper_stroke_s={stroke_s:g} s, so the period is at least "
            f"{low:g} s; or give a mode ({', '.join(map(repr, WIPER_MODES))}) or None for off."
        ) from None


def _sources(rain_rate_mm_h: float, flake_density_m3: float, snow_density: float) -> tuple[np.ndarray, ...]:
    """Size bins of what hits the glass: (number density m⁻³, water-drop diameter m, fall speed m/s)."""
    n, d, w = [], [], []
    if rain_rate_mm_h > 0:
        edges = np.linspace(*RAIN_D_MM, 53)
        lam = marshall_palmer_slope(rain_rate_mm_h)
        n.append(MP_N0 / lam * (np.exp(-lam * edges[:-1]) - np.exp(-lam * edges[1:])))
        mid = 0.5 * (edges[1:] + edges[:-1])
        d.append(mid * 1e-3)
        w.append(terminal_velocity(mid * 5e-4))
    if flake_density_m3 > 0:
        edges = np.linspace(*SNOW_D_MM, 33)
        share = np.exp(-SIZE_SLOPE_PER_MM * edges[:-1]) - np.exp(-SIZE_SLOPE_PER_MM * edges[1:])
        n.append(flake_density_m3 * share / share.sum())
        mid = 0.5 * (edges[1:] + edges[:-1])
        d.append(mid * 1e-3 * (snow_density / _WATER_KG_M3) ** (1.0 / 3.0))  # melted, same mass
        w.append(flake_fall_speed(mid))
    if not n:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    return np.concatenate(n), np.concatenate(d), np.concatenate(w)


def collection_rate(
    rain_rate_mm_h: float,
    speed_m_s: float,
    *,
    flake_density_m3: float = 0.0,
    glass_tilt_deg: float = 55.0,
) -> float:
    """Drops hitting one m² of windscreen per second: ``Σ n_i·(v·cos φ + w_i·sin φ)``.

    Parameters
    ----------
    rain_rate_mm_h : float
        Rain rate (Marshall–Palmer drops of 0.5–7 mm), mm/h.
    speed_m_s : float
        Car speed, m/s (its magnitude counts).
    flake_density_m3 : float
        Snowflakes of 1–5 mm per m³.
    glass_tilt_deg : float
        Tilt φ of the glass back from vertical, degrees.
    """
    rain = check_in_range("rain_rate_mm_h", rain_rate_mm_h, 0.0, 300.0, unit="mm/h")
    snow = check_in_range("flake_density_m3", flake_density_m3, 0.0, 20000.0, unit="1/m^3")
    v = abs(check_in_range("speed_m_s", speed_m_s, -100.0, 100.0, unit="m/s"))
    phi = math.radians(check_in_range("glass_tilt_deg", glass_tilt_deg, 0.0, 90.0, unit="degrees"))
    n, _, w = _sources(rain, snow, _WATER_KG_M3)  # the flakes' density sets their drops' size, not the rate
    return float(np.sum(n * (v * math.cos(phi) + w * math.sin(phi))))


def slide_velocity(radius_m: np.ndarray, speed_m_s: float, params: WindscreenParams) -> np.ndarray:
    """Velocity of drops along the glass, m/s (+ up the glass), see the module docstring."""
    q = params.slide_radius_mm * 1e-3 / np.maximum(np.asarray(radius_m, float), 1e-6)
    net = (speed_m_s / params.airflow_speed_m_s) ** 2 * q - 1.0
    excess = np.abs(net) - q * q
    return np.where(excess > 0.0, np.sign(net) * params.slide_speed_m_s * np.minimum(excess, 2.0), 0.0)
