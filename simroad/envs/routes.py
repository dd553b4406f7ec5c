"""Walks along highway-env's lane successors: the one rule both routes and look-aheads use."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

__all__ = ["MAX_LAP_LANES", "follow_lanes", "lap_length_m"]

#: Lanes walked at most when measuring a lap (simroad's rings have a few dozen).
MAX_LAP_LANES = 200


def follow_lanes(network: Any, start: tuple[str, str, int], *, position: np.ndarray) -> Iterator[tuple[Any, Any]]:
    """Yield ``(lane_index, lane)`` from ``start`` along highway-env's lane successors.

    The walk ends at a dead end (a lane without successor, or whose only
    continuation is on the same road segment); on a ring it goes on forever, so
    consumers stop it. Scenario roads have one successor per lane: the fixed
    generator passed to highway-env's ``next_lane`` only breaks ties, so the walk is
    deterministic.

    Parameters
    ----------
    network : highway_env.road.road.RoadNetwork
    start : (str, str, int)
        Lane index to start from (yielded first).
    position : ndarray of float, shape (2,)
        World position (m) highway-env uses to choose among successors.
    """
    index = start
    while True:
        yield index, network.get_lane(index)
        nxt = network.next_lane(index, route=None, position=position, np_random=np.random.default_rng(0))
        if nxt is None or nxt[:2] == index[:2]:
            return
        index = nxt


def lap_length_m(network: Any, start: tuple[str, str, int], *, position: np.ndarray) -> float | None:
    """Length in m of the lane ring through ``start`` (summed lane lengths), or None
    when the successors do not lead back to ``start`` within :data:`MAX_LAP_LANES` lanes."""
    total = 0.0
    for k, (index, lane) in enumerate(follow_lanes(network, start, position=position)):
        if k > 0 and index == start:
            return total
        if k == MAX_LAP_LANES:
            break
        total += float(lane.length)
    return None
