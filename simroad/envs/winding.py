"""``winding``: a procedurally generated two-lane country road, new for every seed.

The road is a chain of straight and circular segments (highway-env ``StraightLane``
and ``CircularLane``), one lane per direction. Its heading is kept within
``max_heading_deg`` of the initial direction, so the road always advances along +x
and can never cross itself, whatever the seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from highway_env.road.lane import CircularLane, LineType, StraightLane
from highway_env.road.road import Road, RoadNetwork
from highway_env.vehicle.behavior import IDMVehicle

from simroad.core.validation import normalize_rng
from simroad.envs._generated import GeneratedRoadEnv
from simroad.envs._network import IndexedNetwork
from simroad.envs.scenarios import ScenarioSpec

__all__ = ["Segment", "WindingRoadEnv", "build_winding_network", "generate_segments", "make_winding"]

_S, _C, _N = LineType.STRIPED, LineType.CONTINUOUS, LineType.NONE


@dataclass(frozen=True)
class Segment:
    """One piece of the road centre line: ``radius_m`` is 0 for a straight.

    ``turn_rad`` is positive for a right turn (heading increases in highway-env's
    y-down world), negative for a left turn.
    """

    length_m: float
    radius_m: float = 0.0
    turn_rad: float = 0.0


def generate_segments(
    rng: np.random.Generator | int,
    *,
    length_m: float = 2000.0,
    min_radius_m: float = 45.0,
    max_radius_m: float = 250.0,
    max_heading_deg: float = 70.0,
) -> list[Segment]:
    """Draw a random sequence of straights and arcs of total length >= ``length_m``.

    Parameters
    ----------
    rng : numpy.random.Generator
    length_m : float
        Minimum total centre-line length in metres.
    min_radius_m, max_radius_m : float
        Range of centre-line radii in metres.
    max_heading_deg : float
        Bound on the heading relative to the start, in degrees (< 90 keeps the road
        monotone in x, hence free of self-intersections).
    """
    rng = normalize_rng(rng)
    segments: list[Segment] = [Segment(float(rng.uniform(60.0, 100.0)))]  # a calm start
    heading, total = 0.0, segments[0].length_m
    limit = math.radians(max_heading_deg)
    while total < length_m:
        if segments[-1].radius_m == 0.0 or rng.random() < 0.3:
            radius = float(np.exp(rng.uniform(np.log(min_radius_m), np.log(max_radius_m))))
            turn = float(rng.uniform(math.radians(15), math.radians(80)))
            sign = 1.0 if rng.random() < 0.5 else -1.0
            # Turn towards the allowed heading band when near its edge.
            if abs(heading + sign * turn) > limit:
                sign = -sign
            turn = min(turn, limit - sign * heading)
            if turn < math.radians(5):
                continue
            seg = Segment(radius * turn, radius, sign * turn)
            heading += sign * turn
        else:
            seg = Segment(float(rng.uniform(30.0, 160.0)))
        segments.append(seg)
        total += seg.length_m
    segments.append(Segment(80.0))  # straight run-out after the finish
    return segments


def build_winding_network(segments: list[Segment], *, lane_width_m: float) -> tuple[RoadNetwork, list[str]]:
    """Build a two-lane network: forward lanes ``f{k} -> f{k+1}``, oncoming ``o{k+1} -> o{k}``.

    Returns the network and the ordered forward node names.
    """
    net = IndexedNetwork()  # highway-env's network with an exact, faster closest-lane search
    p = np.zeros(2)
    h = 0.0
    hw = lane_width_m / 2.0
    nodes = [f"f{k}" for k in range(len(segments) + 1)]
    for k, seg in enumerate(segments):
        fwd = np.array([math.cos(h), math.sin(h)])
        right = np.array([-math.sin(h), math.cos(h)])
        fa, fb, oa, ob = f"f{k}", f"f{k + 1}", f"o{k + 1}", f"o{k}"
        if seg.radius_m == 0.0:
            q = p + seg.length_m * fwd
            net.add_lane(fa, fb, StraightLane(p + hw * right, q + hw * right, width=lane_width_m, line_types=(_S, _C)))
            net.add_lane(oa, ob, StraightLane(q - hw * right, p - hw * right, width=lane_width_m, line_types=(_N, _C)))
            p = q
        else:
            R, d = seg.radius_m, abs(seg.turn_rad)
            if seg.turn_rad > 0:  # right turn: centre on the right
                c = p + R * right
                phi0 = math.atan2(p[1] - c[1], p[0] - c[0])
                net.add_lane(
                    fa,
                    fb,
                    CircularLane(c, R - hw, phi0, phi0 + d, clockwise=True, width=lane_width_m, line_types=(_S, _C)),
                )
                net.add_lane(
                    oa,
                    ob,
                    CircularLane(c, R + hw, phi0 + d, phi0, clockwise=False, width=lane_width_m, line_types=(_N, _C)),
                )
                phi1 = phi0 + d
            else:  # left turn: centre on the left
                c = p - R * right
                phi0 = math.atan2(p[1] - c[1], p[0] - c[0])
                net.add_lane(
                    fa,
                    fb,
                    CircularLane(c, R + hw, phi0, phi0 - d, clockwise=False, width=lane_width_m, line_types=(_S, _C)),
                )
                net.add_lane(
                    oa,
                    ob,
                    CircularLane(c, R - hw, phi0 - d, phi0, clockwise=True, width=lane_width_m, line_types=(_N, _C)),
                )
                phi1 = phi0 - d
            p = c + R * np.array([math.cos(phi1), math.sin(phi1)])
            h += seg.turn_rad
    return net, nodes


class WindingRoadEnv(GeneratedRoadEnv):
    """A two-lane country road of straights and arcs, generated from the reset seed.

    Config keys beyond highway-env's: ``road_length`` (m, >= 1500 by default 2000),
    ``lane_width`` (m), ``min_radius`` (m), ``leading_vehicles`` and
    ``oncoming_vehicles`` (counts), ``ego_speed`` (m/s).
    """

    scenario_name = "winding"

    @classmethod
    def _road_config(cls, spec: ScenarioSpec) -> dict[str, Any]:
        return {"road_length": 2000.0, "min_radius": 45.0}

    def _reset(self) -> None:
        rng = self.np_random
        self.segments = generate_segments(
            rng, length_m=self.config["road_length"], min_radius_m=self.config["min_radius"]
        )
        net, self.route_nodes = build_winding_network(self.segments, lane_width_m=self.config["lane_width"])
        self.road = Road(network=net, np_random=rng, record_history=self.config["show_trajectories"])
        self._make_vehicles(rng)

    def _make_vehicles(self, rng: np.random.Generator) -> None:
        net = self.road.network
        first = ("f0", "f1", 0)
        ego = self.action_type.vehicle_class(
            self.road,
            net.get_lane(first).position(20.0, 0.0),
            net.get_lane(first).heading_at(20.0),
            self.config["ego_speed"],
        )
        self.controlled_vehicles = [ego]
        self.road.vehicles.append(ego)
        n = len(self.segments)
        for _ in range(int(self.config["leading_vehicles"])):
            k = int(rng.integers(1, min(4, n)))
            lane = net.get_lane((f"f{k}", f"f{k + 1}", 0))
            s = float(rng.uniform(0, lane.length))
            v = IDMVehicle(self.road, lane.position(s, 0.0), lane.heading_at(s), speed=self.config["ego_speed"] * 0.8)
            v.plan_route_to(self.route_nodes[-1])
            self.road.vehicles.append(v)
        for _ in range(int(self.config["oncoming_vehicles"])):
            k = int(rng.integers(1, n))
            lane = net.get_lane((f"o{k + 1}", f"o{k}", 0))
            s = float(rng.uniform(0, lane.length))
            v = IDMVehicle(self.road, lane.position(s, 0.0), lane.heading_at(s), speed=float(rng.uniform(10, 16)))
            v.plan_route_to("o0")
            self.road.vehicles.append(v)


def make_winding(spec: ScenarioSpec, longitudinal: bool, traffic: bool, duration_s: float) -> WindingRoadEnv:
    """The winding scenario's environment (the entry point of ``SCENARIOS["winding"]``)."""
    config = spec.highway_env_config(longitudinal=longitudinal, traffic=traffic, duration_s=duration_s)
    return WindingRoadEnv(config={"lane_width": spec.lane_width_m, **config})
