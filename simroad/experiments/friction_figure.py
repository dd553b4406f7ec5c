"""What the weather does to the car: braking distance and cornering speed, simulated.

Both are measured on highway-env's own vehicle with simroad's friction
(:mod:`simroad.envs.tyres`), μ from each weather (:func:`~simroad.envs.friction.road_grip`):
the braking distance from 25 m/s under a braking demand beyond any tyre's grip, and
the highest speed at which pure pursuit holds a 50 m circle for 8 s without
sliding (found by bisection). ``simroad figure friction`` draws them next to the
theory ``v²/(2·μ·g)`` and ``sqrt(μ·g·R)``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from simroad.control.autopilot import STEERING_RANGE_RAD, autopilot_action
from simroad.envs.friction import RoadGrip, cornering_speed_m_s, road_grip, stopping_distance_m
from simroad.envs.tyres import attach_grip
from simroad.experiments._plotting import save_figure, start_figure
from simroad.experiments.figures import check_figure_path
from simroad.noise import make_weather

__all__ = ["FIGURE_WEATHERS", "friction_figure", "simulated_braking_m", "simulated_cornering_m_s", "weather_grips"]

#: (label, noise, severity, road_surface) of the figure's bars.
FIGURE_WEATHERS: tuple[tuple[str, str, float, str], ...] = (
    ("clear", "clear", 0.0, "auto"),
    ("rain 0.25", "rain", 0.25, "auto"),
    ("rain 0.5", "rain", 0.5, "auto"),
    ("rain 0.8", "rain", 0.8, "auto"),
    ("rain 1", "rain", 1.0, "auto"),
    ("snow 0.5", "snow", 0.5, "auto"),
    ("snow 0.8", "snow", 0.8, "auto"),
    ("snow 1", "snow", 1.0, "auto"),
    ("packed snow", "clear", 0.0, "snow"),
    ("ice", "clear", 0.0, "ice"),
)
_DT = 1.0 / 15.0  # highway-env's physics step in every scenario


def weather_grips() -> list[tuple[str, RoadGrip]]:
    """(label, road friction) of every weather of :data:`FIGURE_WEATHERS`."""

    out = []
    for label, noise, severity, surface in FIGURE_WEATHERS:
        weather = make_weather(noise, severity=severity)
        weather.reset(0)
        out.append((label, road_grip(weather, road_surface=surface)))
    return out


def _road(lane):
    from highway_env.road.road import Road, RoadNetwork

    net = RoadNetwork()
    net.add_lane("a", "b", lane)
    return Road(network=net, np_random=np.random.default_rng(0))


def simulated_braking_m(grip: RoadGrip, speed_m_s: float = 25.0) -> float:
    """Distance in m a highway-env car needs to stop from ``speed_m_s`` on ``grip``."""
    from highway_env.road.lane import StraightLane
    from highway_env.vehicle.kinematics import Vehicle

    road = _road(StraightLane([0.0, 0.0], [1e4, 0.0]))
    car = Vehicle(road, [0.0, 0.0], 0.0, speed_m_s)
    road.vehicles.append(car)
    attach_grip(road, grip)
    car.act({"steering": 0.0, "acceleration": -100.0})
    while car.speed > 0.0:
        car.step(_DT)
    return float(car.position[0])


def _holds(grip: RoadGrip, speed: float, radius: float, seconds: float = 8.0) -> bool:
    from highway_env.road.lane import CircularLane
    from highway_env.vehicle.kinematics import Vehicle

    lane = CircularLane([0.0, 0.0], radius, -math.pi / 2, 1.5 * math.pi, clockwise=True, width=3.5)
    road = _road(lane)
    car = Vehicle(road, lane.position(0.0, 0.0), lane.heading_at(0.0), speed)
    road.vehicles.append(car)
    attach_grip(road, grip)
    for k in range(int(seconds / _DT)):
        if k % 3 == 0:
            car.act({"steering": autopilot_action(road, car) * STEERING_RANGE_RAD, "acceleration": 0.0})
        car.step(_DT)
        if car.sliding or abs(lane.local_coordinates(car.position)[1]) > 1.0:
            return False
    return True


def simulated_cornering_m_s(grip: RoadGrip, radius_m: float = 50.0, *, iterations: int = 14) -> float:
    """Highest speed (m/s) at which a highway-env car steered by pure pursuit holds a
    circle of ``radius_m`` for 8 s without sliding, by bisection."""
    lo, hi = 0.5 * cornering_speed_m_s(grip.mu, radius_m), 1.5 * cornering_speed_m_s(grip.mu, radius_m)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _holds(grip, mid, radius_m) else (lo, mid)
    return lo


def friction_figure(out: str | os.PathLike, *, speed_m_s: float = 25.0, radius_m: float = 50.0) -> Path:
    """Braking distance from ``speed_m_s`` and cornering speed on ``radius_m``, per
    weather of :data:`FIGURE_WEATHERS`, simulated (bars) and in theory (dots). Writes a PNG."""

    out = check_figure_path("out", out)
    plt = start_figure(out)
    grips = weather_grips()
    labels = [f"{label}\nμ={grip.mu:.2f}" for label, grip in grips]
    brake = [simulated_braking_m(g, speed_m_s) for _, g in grips]
    corner = [simulated_cornering_m_s(g, radius_m) for _, g in grips]
    y = np.arange(len(grips))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
    a.barh(y, brake, color="#4a6fa5", label="simulated (highway-env + friction circle)")
    a.plot([stopping_distance_m(speed_m_s, g.mu) for _, g in grips], y, "k.", label="v²/(2μg)")
    a.axvline(speed_m_s**2 / 10.0, color="#c44", ls="--", lw=1, label="highway-env's action range (5 m/s²) alone")
    a.set_xlabel(f"braking distance from {speed_m_s:g} m/s, m")
    b.barh(y, corner, color="#6a9a58", label="simulated: holds the lane, no sliding")
    b.plot([cornering_speed_m_s(g.mu, radius_m) for _, g in grips], y, "k.", label="sqrt(μgR)")
    b.set_xlabel(f"cornering speed on a {radius_m:g} m radius, m/s")
    a.set_yticks(y, labels, fontsize=8)
    a.invert_yaxis()
    for ax, where in ((a, "upper right"), (b, "lower right")):
        ax.legend(fontsize=7, loc=where)
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle("simroad: what the weather does to the car (μ from the weather models)", fontsize=10)
    save_figure(fig, out, dpi=90)
    return out
