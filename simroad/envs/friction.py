"""Tyre–road friction from the weather: μ per road point, and the friction circle.

Physics
-------
* **Friction circle** — a tyre transmits at most ``μ·N`` in any direction, so the
  car's combined acceleration obeys ``sqrt(a_long² + a_lat²) <= μ·g`` (Pacejka,
  *Tyre and Vehicle Dynamics*, ch. 1: the combined-slip force envelope, a circle for
  an isotropic tyre). A demand outside it is scaled back onto the circle in its own
  direction (:func:`friction_limit`): the tyres slide, the car turns less than it
  steered (understeer, a wider curve) and brakes less than it asked.
* **Stopping and cornering** — braking at the limit stops in ``v²/(2·μ·g)``
  (:func:`stopping_distance_m`); a curve of radius R is held up to ``sqrt(μ·g·R)``
  (:func:`cornering_speed_m_s`).
* **μ of a surface** — :data:`SURFACES`, peak tyre–road friction of a passenger car
  at 50–80 km/h; each row gives the value used, the range published and the
  sources (docs/friction.md has the table with its references).
* **Rain** — the water film above the texture tops, from the rain rate by the Road
  Research Laboratory formula (Ross & Russam 1968): ``d = 0.046·(L·I/S)^0.5`` mm, L
  the drainage path (m: one 3.5 m lane of a crowned road), I the rain rate (mm/h),
  S the crossfall (%: 2.5); at least ``water_film`` mm where the rain model lets
  standing water mirror the sky. Wet friction falls with that depth
  (:func:`wet_mu`, :data:`WET_MU_CURVE`); ``wetness``, the soaked fraction of the
  surface, blends dry into wet.
* **Snow** — falling snow melts on a travelled road: the bare road is wet (the
  damp end of the wet curve) with slush on the fraction ``settle`` of it that the
  snow model also covers beside the road; with ``settle_on_road`` the settled
  cover of each point (the patches the picture shows, :meth:`SnowModel.cover_at`)
  is packed snow.
* **Glare** — its ``wetness`` (a road after a shower) is a damp road.
* Composed weathers take the lowest μ of their parts; ``ice`` (and every other
  surface of the table) is an explicit option (``road_surface="ice"``), as is a
  fixed ``mu``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from simroad.core.constants import GRAVITY_M_S2
from simroad.core.validation import check_choice, check_in_range
from simroad.errors import InvalidParameterError

__all__ = [
    "DRAINAGE_PATH_M",
    "MU_RANGE",
    "ROAD_SURFACES",
    "SURFACES",
    "WET_MU_CURVE",
    "RoadGrip",
    "Surface",
    "check_mu",
    "cornering_speed_m_s",
    "friction_limit",
    "road_grip",
    "stopping_distance_m",
    "water_film_depth_mm",
    "wet_mu",
]

#: Accepted range of a friction coefficient (``mu``): above 0, at most a racing slick's.
MU_RANGE = (0.0, 1.5)
#: Drainage path length of the water film model, m (one lane of a crowned road).
DRAINAGE_PATH_M = 3.5
#: Crossfall of the road, % (a common design value).
CROSSFALL_PCT = 2.5


@dataclass(frozen=True)
class Surface:
    """One row of the μ table: the value used, the published range and its sources."""

    mu: float
    low: float
    high: float
    sources: str


#: Road surface name -> μ (peak tyre–road friction, passenger car, 50–80 km/h).
SURFACES: Mapping[str, Surface] = MappingProxyType(
    {
        "dry": Surface(0.80, 0.70, 0.90, "handbook tables (asphalt concrete 0.70-0.80); Noon 1994 (0.65-0.75)"),
        "wet": Surface(0.50, 0.40, 0.60, "handbook tables (0.45-0.55); Noon 1994 (0.50); by film depth: WET_MU_CURVE"),
        "slush": Surface(0.30, 0.20, 0.35, "Ruzinskas et al. 2021 (tyre tests on slush); winter-road reviews"),
        "snow": Surface(0.25, 0.20, 0.35, "handbook tables (packed snow 0.25-0.35); Noon 1994 (0.20-0.25)"),
        "ice": Surface(0.10, 0.05, 0.15, "handbook tables (glaze ice 0.05-0.15); Noon 1994 (0.10-0.15)"),
    }
)
#: Values of the ``road_surface`` option: ``auto`` (from the weather) or a row of :data:`SURFACES`.
ROAD_SURFACES: tuple[str, ...] = ("auto", *SURFACES)

#: Wet friction against water film depth above the texture (mm, μ), piecewise linear.
#: A damp road (film within the texture) already loses a third of its dry friction
#: (Do et al. 2014: 30-40 %); wet asphalt is 0.45-0.55 up to about 1 mm (handbook
#: tables, Noon 1994); deeper water lifts the tyre towards aquaplaning (Gunaratne et
#: al. 2015, friction falls with film thickness and speed). Held at 0.25 beyond 4 mm.
WET_MU_CURVE: tuple[tuple[float, float], ...] = ((0.0, 0.55), (0.5, 0.50), (1.0, 0.45), (2.0, 0.35), (4.0, 0.25))
#: Depth (mm) of standing water where the rain model's ``water_film`` mirrors the sky.
STANDING_WATER_MM = 1.0


def check_mu(name: str, value: Any) -> float:
    """``value`` as a friction coefficient in (0, 1.5], refused by ``name`` otherwise."""
    return check_in_range(name, value, *MU_RANGE, low_inclusive=False)


def water_film_depth_mm(
    rate_mm_h: float, *, drainage_m: float = DRAINAGE_PATH_M, crossfall_pct: float = CROSSFALL_PCT
) -> float:
    """Water depth above the texture of a road in steady rain, mm (Ross & Russam 1968).

    ``d = 0.046·(L·I/S)^0.5``: 0.13 mm at 6 mm/h, 0.27 at 25, 0.54 at 100 (L = 3.5 m,
    S = 2.5 %).

    Parameters
    ----------
    rate_mm_h : float
        Rain rate I, mm/h.
    drainage_m : float
        Drainage path length L, m.
    crossfall_pct : float
        Slope of the drainage path S, %.
    """
    rate = check_in_range("rate_mm_h", rate_mm_h, 0.0, 1000.0, unit="mm/h")
    L = check_in_range("drainage_m", drainage_m, 0.0, 100.0, unit="m", low_inclusive=False)
    S = check_in_range("crossfall_pct", crossfall_pct, 0.0, 50.0, unit="%", low_inclusive=False)
    return 0.046 * math.sqrt(L * rate / S)


def wet_mu(depth_mm: float) -> float:
    """μ of a wet road under ``depth_mm`` of water above its texture (:data:`WET_MU_CURVE`)."""
    d = check_in_range("depth_mm", depth_mm, 0.0, 1000.0, unit="mm")
    xs, ys = zip(*WET_MU_CURVE, strict=True)
    return float(np.interp(d, xs, ys))


def friction_limit(a_long: float, a_lat: float, mu: float, g: float = GRAVITY_M_S2) -> tuple[float, float, bool]:
    """The acceleration the tyres deliver for a demand ``(a_long, a_lat)``, m/s^2.

    Inside the friction circle ``sqrt(a_long² + a_lat²) <= μ·g`` the demand is met;
    outside it both components are scaled by ``μ·g / |a|`` (the resultant force
    saturates in the demanded direction) and the tyres slide.

    Returns
    -------
    a_long, a_lat : float
        Delivered longitudinal and lateral acceleration, m/s^2.
    sliding : bool
        True when the demand exceeded the circle.
    """
    limit = mu * g
    norm = math.hypot(a_long, a_lat)
    if norm <= limit:
        return a_long, a_lat, False
    k = limit / norm
    return a_long * k, a_lat * k, True


def stopping_distance_m(speed_m_s: float, mu: float, g: float = GRAVITY_M_S2) -> float:
    """Distance to stop from ``speed_m_s`` braking at the friction limit: ``v²/(2·μ·g)``, m."""
    return speed_m_s * speed_m_s / (2.0 * mu * g)


def cornering_speed_m_s(mu: float, radius_m: float, g: float = GRAVITY_M_S2) -> float:
    """Highest speed on a curve of ``radius_m`` at the friction limit: ``sqrt(μ·g·R)``, m/s."""
    return math.sqrt(mu * g * radius_m)


class RoadGrip:
    """The friction of an episode's road: μ at any world point.

    Build with :func:`road_grip`. ``mu`` is the bare road's μ; where ``snow`` (a
    :class:`~simroad.noise.SnowModel` with ``settle_on_road``) has settled cover,
    a point's μ blends towards packed snow by the cover fraction.

    Parameters
    ----------
    mu : float
        μ of the bare road.
    snow : SnowModel, optional
        Settled snow on the road (after its ``reset``).
    cover_mu : float
        μ under full snow cover.
    """

    def __init__(self, mu: float, *, snow: Any = None, cover_mu: float = SURFACES["snow"].mu) -> None:
        self.mu = check_mu("mu", mu)
        self.cover_mu = check_mu("cover_mu", cover_mu)
        self.snow = snow

    @property
    def uniform(self) -> bool:
        """True when μ is the same at every point."""
        return self.snow is None

    def mu_at(self, x: float, y: float) -> float:
        """μ at world point (x, y), m."""
        if self.snow is None:
            return self.mu
        c = float(self.snow.cover_at(np.float32(x), np.float32(y)))
        return self.mu + c * (min(self.cover_mu, self.mu) - self.mu)

    def __repr__(self) -> str:
        patches = ", snow patches" if self.snow is not None else ""
        return f"RoadGrip(mu={self.mu:.3f}{patches})"


def _rain_mu(p: Any) -> float:
    depth = max(water_film_depth_mm(p.rate_mm_h), p.water_film * STANDING_WATER_MM)
    dry = SURFACES["dry"].mu
    return dry + p.wetness * (wet_mu(depth) - dry)


def _snow_mu(p: Any) -> float:
    if p.flake_density_m3 == 0.0 and p.settle == 0.0:
        return SURFACES["dry"].mu
    damp = wet_mu(0.0)
    return damp + p.settle * (SURFACES["slush"].mu - damp) if not p.settle_on_road else damp


def _glare_mu(p: Any) -> float:
    dry = SURFACES["dry"].mu
    return dry + p.wetness * (wet_mu(0.0) - dry)


_BY_NOISE = {"rain": _rain_mu, "snow": _snow_mu, "glare": _glare_mu}


def road_grip(weather: Any = None, *, road_surface: str = "auto", mu: float | None = None) -> RoadGrip:
    """The road's friction for a weather (see the module docstring).

    Parameters
    ----------
    weather : Weather, optional
        The episode's :class:`~simroad.noise.Weather` (after ``reset``: settled snow
        patches need the snow model's seed); None is clear weather.
    road_surface : str
        ``"auto"`` (from the weather) or a surface of :data:`SURFACES` (``dry``,
        ``wet``, ``slush``, ``snow``, ``ice``) everywhere.
    mu : float, optional
        A fixed μ in (0, 1.5] everywhere (only with ``road_surface="auto"``).
    """
    road_surface = check_choice("road_surface", road_surface, ROAD_SURFACES)
    if mu is not None:
        if road_surface != "auto":
            raise InvalidParameterError(
                f"mu: a fixed mu={mu!r} and road_surface={road_surface!r} both set the friction; give one of them."
            )
        return RoadGrip(check_mu("mu", mu))
    if road_surface != "auto":
        return RoadGrip(SURFACES[road_surface].mu)
    models = getattr(weather, "models", {}) if weather is not None else {}
    base = min([SURFACES["dry"].mu, *(fn(models[n].params) for n, fn in _BY_NOISE.items() if n in models)])
    snow = models.get("snow")
    if snow is not None and snow.params.settle_on_road and snow.params.settle > 0.0:
        return RoadGrip(base, snow=snow)
    return RoadGrip(base)
