"""The town's parts below the street plan: centre-line pieces, a road that skips
parked cars where they cannot matter, and the parked car itself."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from highway_env.road.lane import AbstractLane, CircularLane, StraightLane
from highway_env.road.road import Road
from highway_env.vehicle.kinematics import Vehicle

__all__ = ["ParkedVehicle", "Piece", "TownRoad"]


@dataclass(frozen=True)
class Piece:
    """A piece of the street's centre line (between the two directions): a straight
    or an arc of signed ``turn`` (rad) starting at ``p`` with heading ``h``."""

    p: tuple[float, float]
    h: float
    length: float
    turn: float = 0.0

    @property
    def radius(self) -> float:
        return self.length / abs(self.turn) if self.turn else math.inf

    def point(self, s: float, lat: float) -> np.ndarray:
        """World point at centre-line arc length ``s`` and ``lat`` m to the right."""
        p, h = np.asarray(self.p), self.h
        if not self.turn:
            return p + s * np.array([math.cos(h), math.sin(h)]) + lat * np.array([-math.sin(h), math.cos(h)])
        hs = h + self.turn * s / self.length
        sign = 1.0 if self.turn > 0 else -1.0
        c = p + sign * self.radius * np.array([-math.sin(h), math.cos(h)])
        return c - sign * (self.radius - sign * lat) * np.array([-math.sin(hs), math.cos(hs)])

    def end(self) -> tuple[tuple[float, float], float]:
        q = self.point(self.length, 0.0)
        return (float(q[0]), float(q[1])), self.h + self.turn

    def lane(self, lat: float, s0: float, s1: float, *, width: float, reverse: bool, line_types) -> AbstractLane:
        """The lane centred ``lat`` m right of the centre line over arc length [s0, s1]."""
        if not self.turn:
            a, b = self.point(s0, lat), self.point(s1, lat)
            if reverse:
                a, b = b, a
            return StraightLane(a, b, width=width, line_types=line_types)
        sign = 1.0 if self.turn > 0 else -1.0
        h = self.h
        c = np.asarray(self.p) + sign * self.radius * np.array([-math.sin(h), math.cos(h)])
        phi0 = math.atan2(self.p[1] - c[1], self.p[0] - c[0])
        pa, pb = phi0 + self.turn * s0 / self.length, phi0 + self.turn * s1 / self.length
        radius = self.radius - sign * lat
        clockwise = self.turn > 0
        if reverse:
            pa, pb, clockwise = pb, pa, not clockwise
        return CircularLane(c, radius, pa, pb, clockwise=clockwise, width=width, line_types=line_types)


class TownRoad(Road):
    """highway-env's road, with parked cars left out of what costs per car pair.

    Parked cars stand on parking strips (roads of their own): no moving car follows
    one, so they are skipped when finding a car's neighbours, and only parked cars
    within reach of a moving one are checked for collisions.
    """

    def neighbour_vehicles(self, vehicle, lane_index=None):
        everyone: list = self.vehicles  # type: ignore[has-type]
        self.vehicles = [v for v in everyone if not isinstance(v, ParkedVehicle)]
        try:
            return super().neighbour_vehicles(vehicle, lane_index)
        finally:
            self.vehicles = everyone

    def step(self, dt: float) -> None:
        moving = [v for v in self.vehicles if not isinstance(v, ParkedVehicle)]
        parked = [v for v in self.vehicles if isinstance(v, ParkedVehicle)]
        for vehicle in moving:
            vehicle.step(dt)
        where = np.array([v.position for v in parked]).reshape(-1, 2)
        for i, vehicle in enumerate(moving):
            for other in moving[i + 1 :]:
                vehicle.handle_collisions(other, dt)
            near = np.hypot(*(where - vehicle.position).T) < 8.0 + vehicle.speed * dt
            for k in np.nonzero(near)[0]:
                vehicle.handle_collisions(parked[k], dt)
            for obj in self.objects:
                vehicle.handle_collisions(obj, dt)


class ParkedVehicle(Vehicle):
    """A parked car: never acts, never moves (not even when hit), still collidable.

    It does not look for other cars itself (``check_collisions = False``): a moving
    car that hits it finds it, so crashes count, while parked pairs cost nothing.
    """

    def __init__(self, road: Road, lane_index, lane: AbstractLane, s: float, lateral: float = 0.0) -> None:
        super().__init__(None, lane.position(s, lateral), lane.heading_at(s), 0.0)
        self.road = road
        self.lane_index, self.lane = lane_index, lane
        self.check_collisions = False

    def act(self, action=None) -> None:
        return None

    def step(self, dt: float) -> None:
        return None
