"""Driving-safety metrics, computed from highway-env's state (never from a mask).

Definitions
-----------
collision
    The ego crashed (highway-env's ``vehicle.crashed``) at any step.
off-road
    Any corner of the ego's footprint lies off the road surface (the union of all
    lanes, as in the ground-truth mask). Counted in steps and as a fraction of steps;
    ``offroad_events`` counts entries.
lane departure
    An event where a footprint corner leaves the lane the ego's centre is in
    (``|lateral| > width / 2``), counted on entry.
lateral error
    Distance of the ego's centre to the centre of its closest lane: RMS and max (m).
heading error
    Ego heading minus lane heading, RMS in degrees.
distance, route completion
    ``distance_m`` is the odometer; progress along the road is the odometer weighted
    by the cosine of the heading error; ``route_completion`` is progress divided by
    the route length, capped at 1.
time-to-collision
    For the vehicle ahead in the ego's lane (highway-env's ``neighbour_vehicles``),
    gap / closing speed when closing; ``min_ttc_s`` is the minimum over the
    episode (inf if never closing). Oncoming traffic in its own lane does not count.
stopping margin
    For the same vehicle ahead, gap minus the ego's stopping distance
    ``v²/(2·a)``, with ``a = min(5 m/s², μ·g)``: the braking of highway-env's
    action range, limited by the tyre–road friction ``info["mu"]`` (the action
    range alone when the environment runs without friction).
    ``min_stopping_margin_m`` is the minimum over the episode (inf if no vehicle
    was ever ahead); negative means the ego could not have stopped short of where
    the car ahead was.
sliding, speed
    ``slide_steps`` counts steps in which the tyres slid (``info["sliding"]``);
    ``mean_speed_m_s`` is the odometer over the time driven.
driving score
    In the spirit of the CARLA leaderboard: ``route_completion x product of
    penalties``, with one factor per infraction: vehicle collision 0.60, off-road
    event 0.65 (CARLA's collision-with-layout factor), lane departure 0.95.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from highway_env.envs.common.action import ContinuousAction

from simroad.core.constants import GRAVITY_M_S2
from simroad.core.lanes import lane_signed_distance, supports_vectorised
from simroad.core.validation import check_in_range
from simroad.errors import InvalidParameterError

__all__ = ["PENALTIES", "SafetyScore", "footprint_corners"]

#: Multiplicative penalty per infraction in the driving score.
PENALTIES = {"collision": 0.60, "offroad": 0.65, "lane_departure": 0.95}
#: Hardest braking highway-env's continuous action asks for, m/s^2.
BRAKE_M_S2 = -float(ContinuousAction.ACCELERATION_RANGE[0])


def footprint_corners(vehicle) -> np.ndarray:
    """World (x, y) of the 4 corners of a highway-env vehicle's footprint, (4, 2)."""
    if not all(hasattr(vehicle, a) for a in ("position", "heading", "LENGTH", "WIDTH")):
        raise InvalidParameterError(
            f"vehicle: expected a highway-env Vehicle (env.vehicle), got {type(vehicle).__name__}."
        )
    h = float(vehicle.heading)
    fwd = np.array([math.cos(h), math.sin(h)])
    right = np.array([-math.sin(h), math.cos(h)])
    hl, hw = vehicle.LENGTH / 2.0, vehicle.WIDTH / 2.0
    c = np.asarray(vehicle.position, dtype=float)
    return np.array(
        [c + hl * fwd - hw * right, c + hl * fwd + hw * right, c - hl * fwd + hw * right, c - hl * fwd - hw * right]
    )


def _on_road(network, pts: np.ndarray, first=None) -> np.ndarray:
    """Which points lie on the road surface (the union of all lanes). ``first``, a
    lane to try before the others (the car's own), only saves time: the search stops
    once every point lies on some lane."""
    on = np.zeros(len(pts), bool)
    lanes = network.lanes_list()
    for lane in lanes if first is None else [first, *lanes]:
        if supports_vectorised(lane):
            on |= lane_signed_distance(lane, pts[:, 0], pts[:, 1]) >= 0.0
        else:
            on |= np.array([lane.on_lane(p) for p in pts], bool)
        if on.all():
            break
    return on


@dataclass
class SafetyScore:
    """Accumulates safety metrics over an episode; call :meth:`update` every step.

    Parameters
    ----------
    dt : float
        Seconds per step.
    route_length_m : float
        Length of the route the driver is asked to cover.
    """

    dt: float
    route_length_m: float
    steps: int = 0
    collided: bool = False
    collisions: int = 0
    offroad_steps: int = 0
    offroad_events: int = 0
    lane_departures: int = 0
    distance_m: float = 0.0
    progress_m: float = 0.0
    min_ttc_s: float = math.inf
    min_stopping_margin_m: float = math.inf
    slide_steps: int = 0
    _lat: list[float] = field(default_factory=list)
    _head: list[float] = field(default_factory=list)
    _was_off: bool = False
    _was_departed: bool = False
    _was_crashed: bool = False

    def __post_init__(self) -> None:
        check_in_range("dt", self.dt, 0.0, 60.0, unit="s", low_inclusive=False)
        check_in_range("route_length_m", self.route_length_m, 0.0, 1e9, unit="m")

    def update(self, road, vehicle, info: dict) -> None:
        """Record one step from the highway-env ``road`` and ego ``vehicle``."""
        self.steps += 1
        crashed = bool(vehicle.crashed)
        if crashed and not self._was_crashed:
            self.collisions += 1
        self.collided |= crashed
        self._was_crashed = crashed
        corners = footprint_corners(vehicle)
        lane = road.network.get_lane(road.network.get_closest_lane_index(vehicle.position, vehicle.heading))
        off = not bool(_on_road(road.network, corners, first=lane).all())
        self.offroad_steps += int(off)
        self.offroad_events += int(off and not self._was_off)
        self._was_off = off
        half = lane.width_at(0.0) / 2.0
        departed = any(abs(lane.local_coordinates(c)[1]) > half for c in corners)
        self.lane_departures += int(departed and not self._was_departed)
        self._was_departed = departed
        self._lat.append(float(info["lateral_offset_m"]))
        herr = float(info["heading_error_rad"])
        self._head.append(herr)
        step = float(vehicle.speed) * self.dt
        self.distance_m += step
        self.progress_m += step * math.cos(herr)
        self.slide_steps += int(bool(info.get("sliding", False)))
        front = _front(road, vehicle)
        if front is not None:
            gap, closing = front
            self.min_ttc_s = min(self.min_ttc_s, gap / closing if closing > 1e-6 else math.inf)
            mu = info.get("mu")
            brake = BRAKE_M_S2 if mu is None else min(BRAKE_M_S2, float(mu) * GRAVITY_M_S2)
            margin = gap - max(0.0, float(vehicle.speed)) ** 2 / (2.0 * brake)
            self.min_stopping_margin_m = min(self.min_stopping_margin_m, margin)

    def result(self) -> dict[str, float | int | bool]:
        """The metrics as a flat dict (keys of the episode record)."""
        lat = np.asarray(self._lat) if self._lat else np.zeros(1)
        head = np.degrees(np.asarray(self._head)) if self._head else np.zeros(1)
        completion = min(1.0, max(0.0, self.progress_m) / self.route_length_m) if self.route_length_m > 0 else 0.0
        score = completion
        score *= PENALTIES["collision"] ** self.collisions
        score *= PENALTIES["offroad"] ** self.offroad_events
        score *= PENALTIES["lane_departure"] ** self.lane_departures
        return {
            "collided": self.collided,
            "offroad_steps": self.offroad_steps,
            "offroad_fraction": self.offroad_steps / max(1, self.steps),
            "lane_departures": self.lane_departures,
            "lateral_rmse_m": float(np.sqrt(np.mean(lat**2))),
            "lateral_max_m": float(np.max(np.abs(lat))),
            "heading_rmse_deg": float(np.sqrt(np.mean(head**2))),
            "distance_m": self.distance_m,
            "route_completion": completion,
            "min_ttc_s": self.min_ttc_s,
            "min_stopping_margin_m": self.min_stopping_margin_m,
            "slide_steps": self.slide_steps,
            "mean_speed_m_s": self.distance_m / (self.steps * self.dt) if self.steps else 0.0,
            "driving_score": score,
        }


def _front(road, ego) -> tuple[float, float] | None:
    """(gap in m, closing speed in m/s) to the vehicle ahead in the ego's lane
    (highway-env's ``road.neighbour_vehicles``, which also searches the connected
    next lane), or None when there is none."""
    front, _ = road.neighbour_vehicles(ego, ego.lane_index)
    if front is None:
        return None
    gap = float(np.linalg.norm(np.asarray(front.position) - np.asarray(ego.position))) - (ego.LENGTH + front.LENGTH) / 2
    closing = float(ego.speed) - float(front.speed) * math.cos(float(front.heading) - float(ego.heading))
    return max(gap, 0.0), closing
