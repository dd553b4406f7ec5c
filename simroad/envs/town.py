"""``town``: a procedurally generated town street with junctions, parking and crossings.

The main street is a chain of blocks (straights and gentle arcs), one lane per
direction, with a cross street at the end of every block: a junction the route
crosses straight on. Cross streets are separate highway-env roads that end at the
main carriageway's edge, so the main street's lanes (and nothing else) run through
the junction box and the ego's lane successors never turn. Parking strips (asphalt
lanes beside the kerb, on separate roads so that no car changes lane into them)
line some blocks and hold parked cars; zebra crossings and stop lines before some
junctions are world polygons (:attr:`TownStreetEnv.crossing_polygons`) the world
paints as road markings. Kerbs and sidewalks are the world's ``urban`` profile,
beyond the road edge; every edge line is ``LineType.NONE``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from highway_env.road.lane import AbstractLane, LineType, StraightLane
from highway_env.road.road import RoadNetwork
from highway_env.vehicle.behavior import IDMVehicle

from simroad.core.validation import normalize_rng
from simroad.envs._generated import GeneratedRoadEnv
from simroad.envs._network import IndexedNetwork
from simroad.envs._town_parts import ParkedVehicle, Piece, TownRoad
from simroad.envs.scenarios import ScenarioSpec

__all__ = [
    "Block",
    "TownLayout",
    "TownNetwork",
    "TownStreetEnv",
    "build_town_network",
    "generate_town",
    "make_town",
]

_S, _C, _N = LineType.STRIPED, LineType.CONTINUOUS, LineType.NONE
#: Zebra stripes: width across the road and gap between two, in m.
ZEBRA_STRIPE_M = 0.5
#: Width of a stop line along the road, in m.
STOP_LINE_M = 0.3
#: Length of the approach piece before a junction (stop line, zebra), in m.
APPROACH_M = 9.0
#: Continuous centre line before the approach piece, in m.
NO_OVERTAKING_M = 15.0
#: Free kerb between a parking strip and a junction's approach, in m.
PARKING_MARGIN_M = 6.0
#: Parking slot length (one car and its gaps), in m.
PARKING_SLOT_M = 6.0


@dataclass(frozen=True)
class Block:
    """One block of the main street and the junction at its end.

    ``turn_rad`` > 0 bends right (highway-env's y-down world), 0 is a straight.
    ``cross_left``/``cross_right``: the cross street leaves on that side (a
    T-junction has one). ``parking_right`` is the ego's kerb, ``parking_left`` the
    oncoming one.
    """

    length_m: float
    turn_rad: float
    parking_right: bool
    parking_left: bool
    crossing: bool
    cross_left: bool
    cross_right: bool


@dataclass(frozen=True)
class TownLayout:
    """The drawn street: blocks and the widths (m) of lanes, parking and cross streets."""

    blocks: tuple[Block, ...]
    lane_width_m: float
    parking_width_m: float
    cross_lane_width_m: float
    cross_length_m: float
    zebra_length_m: float
    centre_striped: bool


def generate_town(
    rng: np.random.Generator | int,
    *,
    length_m: float = 800.0,
    lane_width_m: float = 3.25,
    max_heading_deg: float = 25.0,
    ego_side_parking: bool = False,
) -> TownLayout:
    """Draw blocks of 60-120 m until the main street is >= ``length_m`` long.

    Arcs are gentle (radius >= 150 m); the heading stays within ``max_heading_deg``
    of the start, so consecutive cross streets (40-60 m long) never meet. Parking
    strips line the oncoming kerb, and the ego's too with ``ego_side_parking``.
    """
    rng = normalize_rng(rng)
    blocks: list[Block] = []
    heading, total, limit = 0.0, 0.0, math.radians(max_heading_deg)
    while total < length_m:
        length = float(rng.uniform(60.0, 120.0))
        turn = 0.0
        if rng.random() < 0.4:
            turn = float(rng.uniform(math.radians(3.0), math.radians(10.0))) * (1 if rng.random() < 0.5 else -1)
            if abs(heading + turn) > limit:
                turn = -turn
            turn = float(np.clip(turn, -length / 150.0, length / 150.0))  # radius >= 150 m
        heading += turn
        sides = int(rng.integers(0, 3))  # 0: four-way, 1: T to the left, 2: T to the right
        blocks.append(
            Block(
                length_m=length,
                turn_rad=turn,
                # The mask lane keeper cannot yet tell the ego's own kerb from a parking
                # strip's beside parked cars: parking only on the oncoming kerb for now.
                parking_right=bool(rng.random() < 0.6) and ego_side_parking,
                parking_left=bool(rng.random() < 0.6),
                crossing=bool(rng.random() < 0.6),
                cross_left=sides != 2,
                cross_right=sides != 1,
            )
        )
        total += length + APPROACH_M + 2 * 3.0
    return TownLayout(
        blocks=tuple(blocks),
        lane_width_m=float(lane_width_m),
        parking_width_m=float(rng.uniform(2.1, 2.5)),
        cross_lane_width_m=float(rng.uniform(2.9, 3.3)),
        cross_length_m=float(rng.uniform(40.0, 60.0)),
        zebra_length_m=float(rng.uniform(3.0, 4.0)),
        centre_striped=bool(rng.random() < 0.7),
    )


@dataclass
class TownNetwork:
    """A built town: the network, the ego's route nodes, the painted polygons and
    the parking strips (lane index, lane) that hold parked cars."""

    network: RoadNetwork
    route_nodes: list[str]
    crossing_polygons: list[np.ndarray]
    parking: list[tuple[tuple[str, str, int], AbstractLane]]
    junction_boxes: list[np.ndarray]


def _rect(piece: Piece, s0: float, s1: float, lat0: float, lat1: float) -> np.ndarray:
    """Polygon (4, 2) of the (s, lat) rectangle on a straight piece."""
    pts = [piece.point(s0, lat0), piece.point(s1, lat0), piece.point(s1, lat1), piece.point(s0, lat1)]
    return np.asarray(pts, dtype=float)


def build_town_network(layout: TownLayout, *, run_in_m: float = 40.0, run_out_m: float = 80.0) -> TownNetwork:
    """Lanes of the town: forward ``f{k} -> f{k+1}``, oncoming ``o{k+1} -> o{k}``,
    cross streets ``x{j}{side}...`` and parking strips ``p{k}{side}a -> ...b``."""
    w, pw = layout.lane_width_m, layout.parking_width_m
    box = 2 * layout.cross_lane_width_m
    centre = _S if layout.centre_striped else _C
    net = IndexedNetwork()
    polys: list[np.ndarray] = []
    boxes: list[np.ndarray] = []
    parking: list[tuple[tuple[str, str, int], AbstractLane]] = []
    nodes = ["f0"]

    def main(piece: Piece, s0: float, s1: float, line: LineType) -> None:
        k = len(nodes) - 1
        net.add_lane(f"f{k}", f"f{k + 1}", piece.lane(w / 2, s0, s1, width=w, reverse=False, line_types=(line, _N)))
        net.add_lane(f"o{k + 1}", f"o{k}", piece.lane(-w / 2, s0, s1, width=w, reverse=True, line_types=(_N, _N)))
        nodes.append(f"f{k + 1}")

    p, h = (0.0, 0.0), 0.0
    pieces = [(run_in_m, 0.0, None)] + [(b.length_m, b.turn_rad, b) for b in layout.blocks]
    for j, (length, turn, block) in enumerate(pieces):
        body = Piece(p, h, length, turn)
        split = max(0.0, length - NO_OVERTAKING_M) if block is not None else length
        main(body, 0.0, split, centre)
        if split < length:
            main(body, split, length, _C)
        if block is not None:
            for side, on in ((1.0, block.parking_right), (-1.0, block.parking_left)):
                s0, s1 = PARKING_MARGIN_M, length - PARKING_MARGIN_M
                if on and s1 - s0 >= 2 * PARKING_SLOT_M:
                    name = f"p{j}{'r' if side > 0 else 'l'}"
                    lane = body.lane(side * (w + pw / 2), s0, s1, width=pw, reverse=side < 0, line_types=(_N, _N))
                    net.add_lane(f"{name}a", f"{name}b", lane)
                    parking.append(((f"{name}a", f"{name}b", 0), lane))
        p, h = body.end()
        if block is None:
            continue
        # The approach: centre line stops, stop line and zebra before the junction.
        approach = Piece(p, h, APPROACH_M)
        main(approach, 0.0, APPROACH_M, _N)
        zl = layout.zebra_length_m
        z1 = APPROACH_M - 1.0
        z0 = z1 - zl if block.crossing else z1
        stop = z0 - 1.5
        polys.append(_rect(approach, stop - STOP_LINE_M, stop, 0.0, w))
        if block.crossing:
            n = int((2 * w + ZEBRA_STRIPE_M) // (2 * ZEBRA_STRIPE_M))
            first = -(n * 2 - 1) * ZEBRA_STRIPE_M / 2
            for i in range(n):
                a = first + 2 * i * ZEBRA_STRIPE_M
                polys.append(_rect(approach, z0, z1, a, a + ZEBRA_STRIPE_M))
        p, h = approach.end()
        # The junction box: main lanes without lines, cross streets ending at its sides.
        junction = Piece(p, h, box)
        main(junction, 0.0, box, _N)
        boxes.append(_rect(junction, 0.0, box, -w, w))
        _cross_streets(net, junction, block, j, layout, polys)
        p, h = junction.end()
    end = Piece(p, h, run_out_m)
    main(end, 0.0, run_out_m, centre)
    return TownNetwork(net, nodes, polys, parking, boxes)


def _cross_streets(
    net: RoadNetwork, junction: Piece, block: Block, j: int, layout: TownLayout, polys: list[np.ndarray]
) -> None:
    """Add the cross street(s) of ``junction``: two lanes each, from the main
    carriageway's edge outwards, a stop line at the end of the inbound lane."""
    w, cw, length = layout.lane_width_m, layout.cross_lane_width_m, layout.cross_length_m
    mid = junction.point(cw, 0.0)
    fwd = np.array([math.cos(junction.h), math.sin(junction.h)])
    right = np.array([-math.sin(junction.h), math.cos(junction.h)])
    gap = 4.0  # no centre line right at the junction
    for side, on in ((1.0, block.cross_right), (-1.0, block.cross_left)):
        if not on:
            continue
        out = side * right  # direction away from the main street
        own = -side * fwd  # the outbound lane's side (drive on the right)
        tag = f"x{j}{'r' if side > 0 else 'l'}"
        a = mid + w * out
        b = a + gap * out
        c = a + length * out
        for lane_from, lane_to, p0, p1, off, lines in (
            (f"{tag}0", f"{tag}1", a, b, own, (_N, _N)),
            (f"{tag}1", f"{tag}2", b, c, own, (_S, _N)),
            (f"{tag}3", f"{tag}4", c, b, -own, (_N, _N)),
            (f"{tag}4", f"{tag}5", b, a, -own, (_N, _N)),
        ):
            start, stop = p0 + off * cw / 2, p1 + off * cw / 2
            net.add_lane(lane_from, lane_to, StraightLane(start, stop, width=cw, line_types=lines))
        # Stop line across the inbound lane, 1 m before the main carriageway.
        s0, s1 = a + 1.0 * out, a + (1.0 + STOP_LINE_M) * out
        polys.append(np.array([s0, s1, s1 - own * cw, s0 - own * cw], dtype=float))


class TownStreetEnv(GeneratedRoadEnv):
    """A town street of blocks and junctions, generated from the reset seed.

    Config keys beyond highway-env's: ``road_length`` (m, main street without
    run-in/out), ``lane_width`` (m), ``leading_vehicles``, ``oncoming_vehicles``
    and ``parked_vehicles`` (counts), ``ego_speed`` (m/s). After reset:
    ``layout`` (:class:`TownLayout`), ``route_nodes``, ``crossing_polygons`` (list
    of (N, 2) world polygons in m: zebra stripes and stop lines, road markings) and
    ``junction_boxes``.
    """

    scenario_name = "town"

    @classmethod
    def _road_config(cls, spec: ScenarioSpec) -> dict[str, Any]:
        return {"road_length": spec.route_m + 40.0}

    def _reset(self) -> None:
        rng = self.np_random
        self.layout = generate_town(rng, length_m=self.config["road_length"], lane_width_m=self.config["lane_width"])
        town = build_town_network(self.layout)
        self.route_nodes = town.route_nodes
        self.crossing_polygons = town.crossing_polygons
        self.junction_boxes = town.junction_boxes
        self.road = TownRoad(network=town.network, np_random=rng, record_history=self.config["show_trajectories"])
        self._make_vehicles(rng, town)

    def _make_vehicles(self, rng: np.random.Generator, town: TownNetwork) -> None:
        net, nodes = self.road.network, self.route_nodes
        first = ("f0", "f1", 0)
        ego = self.action_type.vehicle_class(
            self.road, net.get_lane(first).position(15.0, 0.0), net.get_lane(first).heading_at(15.0),
            self.config["ego_speed"],
        )  # fmt: skip
        self.controlled_vehicles = [ego]
        self.road.vehicles.append(ego)
        n = len(nodes) - 1
        cruise = float(self.config["ego_speed"])
        ahead = np.arange(2, max(3, min(8, n)))
        for k in rng.choice(ahead, size=min(int(self.config["leading_vehicles"]), len(ahead)), replace=False):
            lane = net.get_lane((f"f{k}", f"f{k + 1}", 0))
            s = float(rng.uniform(0, lane.length))
            v = IDMVehicle(self.road, lane.position(s, 0.0), lane.heading_at(s), speed=cruise * 0.8)
            v.plan_route_to(nodes[-1])
            self.road.vehicles.append(v)
        for k in rng.choice(np.arange(2, n), size=min(int(self.config["oncoming_vehicles"]), n - 2), replace=False):
            lane = net.get_lane((f"o{k + 1}", f"o{k}", 0))
            s = float(rng.uniform(0, lane.length))
            v = IDMVehicle(self.road, lane.position(s, 0.0), lane.heading_at(s), speed=float(rng.uniform(8, 13)))
            v.plan_route_to("o0")
            self.road.vehicles.append(v)
        slots = [(index, lane, (i + 0.5) * PARKING_SLOT_M) for index, lane in town.parking
                 for i in range(int(lane.length // PARKING_SLOT_M))]  # fmt: skip
        count = min(int(self.config["parked_vehicles"]), len(slots))
        for i in sorted(rng.choice(len(slots), size=count, replace=False)):
            index, lane, s = slots[i]
            jitter = float(rng.uniform(-0.6, 0.6))
            room = max(0.0, lane.width_at(0.0) / 2 - ParkedVehicle.WIDTH / 2 - 0.05)
            lateral = float(rng.uniform(0.0, room))  # towards the kerb (right of the strip's travel)
            self.road.vehicles.append(ParkedVehicle(self.road, index, lane, s + jitter, lateral))


def make_town(spec: ScenarioSpec, longitudinal: bool, traffic: bool, duration_s: float) -> TownStreetEnv:
    """The town scenario's environment (the entry point of ``SCENARIOS["town"]``)."""
    config = spec.highway_env_config(longitudinal=longitudinal, traffic=traffic, duration_s=duration_s)
    return TownStreetEnv(config={"lane_width": spec.lane_width_m, "road_length": spec.route_m + 40.0, **config})
