"""Tyre–road friction: the μ table, μ from the weather, the friction circle (worked by hand)."""

from __future__ import annotations

import math

import pytest

from simroad.envs import RoadCamConfig
from simroad.envs.friction import (
    SURFACES,
    RoadGrip,
    cornering_speed_m_s,
    friction_limit,
    road_grip,
    stopping_distance_m,
    water_film_depth_mm,
    wet_mu,
)
from simroad.errors import SimroadError
from simroad.noise import RainParams, SnowParams, make_weather


def test_friction_circle_worked_by_hand():
    # mu = 0.5: the circle's radius is 0.5 * 9.81 = 4.905 m/s^2.
    # Braking 3 and turning 3 m/s^2: |a| = sqrt(18) = 4.243 < 4.905, delivered as asked.
    assert friction_limit(-3.0, 3.0, 0.5) == (-3.0, 3.0, False)
    # Braking 4 and turning 3: |a| = 5 > 4.905, both scaled by 4.905 / 5 = 0.981.
    a_long, a_lat, sliding = friction_limit(-4.0, 3.0, 0.5)
    assert sliding
    assert (a_long, a_lat) == pytest.approx((-3.924, 2.943))
    assert math.hypot(a_long, a_lat) == pytest.approx(4.905)
    # On the circle itself the tyres still grip.
    assert friction_limit(0.0, 4.905, 0.5)[2] is False


def test_stopping_and_cornering_by_hand():
    # 25 m/s on wet asphalt (0.5): 625 / (2 * 0.5 * 9.81) = 63.71 m; on ice (0.1): 318.6 m.
    assert stopping_distance_m(25.0, 0.5) == pytest.approx(63.71, abs=0.01)
    assert stopping_distance_m(25.0, 0.1) == pytest.approx(318.55, abs=0.01)
    # R = 50 m, dry (0.8): sqrt(0.8 * 9.81 * 50) = 19.81 m/s.
    assert cornering_speed_m_s(0.8, 50.0) == pytest.approx(19.81, abs=0.01)


def test_table_values_lie_in_their_ranges_and_order():
    for s in SURFACES.values():
        assert 0.0 < s.low <= s.mu <= s.high <= 1.0 and s.sources
    mus = [SURFACES[k].mu for k in ("dry", "wet", "slush", "snow", "ice")]
    assert mus == sorted(mus, reverse=True)


def test_water_film_depth_ross_russam():
    # d = 0.046 * sqrt(L * I / S): L = 3.5 m, I = 25 mm/h, S = 2.5 % -> 0.046 * sqrt(35).
    assert water_film_depth_mm(25.0) == pytest.approx(0.046 * math.sqrt(35.0))
    assert water_film_depth_mm(0.0) == 0.0
    assert water_film_depth_mm(100.0) > water_film_depth_mm(25.0)


def test_wet_mu_falls_with_depth():
    depths = [0.0, 0.3, 0.5, 1.0, 2.0, 4.0, 10.0]
    mus = [wet_mu(d) for d in depths]
    assert all(a >= b for a, b in zip(mus, mus[1:], strict=False))
    assert SURFACES["wet"].low <= wet_mu(0.5) <= SURFACES["wet"].high


def _grip(noise: str, severity: float, **params) -> RoadGrip:
    w = make_weather(noise, severity=severity, params=params or None)
    w.reset(0)
    return road_grip(w)


def test_mu_from_the_weather():
    assert road_grip(None).mu == SURFACES["dry"].mu
    assert _grip("shadow", 0.8).mu == SURFACES["dry"].mu
    rain = [_grip("rain", s).mu for s in (0.0, 0.25, 0.5, 0.8, 1.0)]
    assert rain[0] == SURFACES["dry"].mu
    assert all(a > b for a, b in zip(rain, rain[1:], strict=False)), rain
    assert SURFACES["wet"].low <= rain[3] <= SURFACES["wet"].high
    snow = [_grip("snow", s).mu for s in (0.3, 0.8, 1.0)]
    assert all(a > b for a, b in zip(snow, snow[1:], strict=False)), snow
    assert snow[1] < rain[3]  # slush at 0.8
    # a composed weather is as slippery as its most slippery part
    assert _grip("rain+snow", 0.8).mu == pytest.approx(min(rain[3], snow[1]))
    assert _grip("glare", 0.8).mu < SURFACES["dry"].mu


def test_settled_snow_on_the_road_makes_patches():
    grip = _grip("snow", 1.0, snow=SnowParams(settle=0.6, settle_on_road=True))
    assert not grip.uniform
    mus = [grip.mu_at(x * 0.7, y * 1.3) for x in range(40) for y in range(10)]
    assert min(mus) == pytest.approx(SURFACES["snow"].mu, abs=0.02)
    assert max(mus) > min(mus) + 0.2
    assert mus == [grip.mu_at(x * 0.7, y * 1.3) for x in range(40) for y in range(10)]  # deterministic


def test_explicit_surfaces_and_mu():
    assert road_grip(None, road_surface="ice").mu == SURFACES["ice"].mu
    w = make_weather("rain", severity=1.0, params={"rain": RainParams(rate_mm_h=100.0)})
    assert road_grip(w, road_surface="dry").mu == SURFACES["dry"].mu
    assert road_grip(w, mu=0.33).mu == 0.33


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"road_surface": "sleet"}, "road_surface"),
        ({"road_surface": 3}, "road_surface"),
        ({"mu": 0.0}, "mu"),
        ({"mu": -0.2}, "mu"),
        ({"mu": 2.0}, "mu"),
        ({"mu": float("nan")}, "mu"),
        ({"mu": "high"}, "mu"),
        ({"mu": 0.3, "road_surface": "ice"}, "mu"),
        ({"friction": "yes"}, "friction"),
        ({"friction": False, "road_surface": "ice"}, "road_surface"),
        ({"friction": False, "mu": 0.3}, "mu"),
    ],
)
def test_bad_friction_options_are_refused_by_name(kwargs, name):
    with pytest.raises(SimroadError, match=name):
        RoadCamConfig(**kwargs)


def test_unknown_surface_suggests_the_closest():
    with pytest.raises(SimroadError, match="Did you mean 'slush'"):
        road_grip(None, road_surface="slosh")
