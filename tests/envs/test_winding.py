"""The procedural winding road: length, radii, continuity, no self-intersection."""

from __future__ import annotations

import numpy as np
import pytest
from highway_env.road.lane import CircularLane

from simroad.envs.winding import WindingRoadEnv, build_winding_network, generate_segments


@pytest.mark.parametrize("seed", range(6))
def test_segments_meet_the_spec(seed):
    rng = np.random.default_rng(seed)
    segs = generate_segments(rng, length_m=1500.0)
    assert sum(s.length_m for s in segs) >= 1500.0
    net, nodes = build_winding_network(segs, lane_width_m=3.5)
    forward = [net.get_lane((a, b, 0)) for a, b in zip(nodes[:-1], nodes[1:])]
    for lane in net.lanes_list():
        if isinstance(lane, CircularLane):
            assert lane.radius >= 40.0
    # Consecutive forward lanes join without a gap or a kink.
    for a, b in zip(forward[:-1], forward[1:]):
        np.testing.assert_allclose(a.position(a.length, 0), b.position(0, 0), atol=1e-6)
        da = a.heading_at(a.length) - b.heading_at(0)
        assert abs(np.arctan2(np.sin(da), np.cos(da))) < 1e-6
    # The centre line advances along +x, so the road cannot cross itself.
    xs = np.concatenate([[l.position(s, 0)[0] for s in np.linspace(0, l.length, 20)] for l in forward])
    assert np.all(np.diff(xs) > -1e-6)


def test_oncoming_lane_lies_beside_the_forward_lane():
    segs = generate_segments(np.random.default_rng(1))
    net, _nodes = build_winding_network(segs, lane_width_m=3.5)
    for k in range(len(segs)):
        f = net.get_lane((f"f{k}", f"f{k + 1}", 0))
        o = net.get_lane((f"o{k + 1}", f"o{k}", 0))
        p = f.position(f.length / 2, -3.5)  # one lane width to the left
        s, lat = o.local_coordinates(p)
        assert abs(lat) < 1e-6 and 0 <= s <= o.length + 1e-6


def test_every_seed_gives_a_different_road():
    def shape(seed):
        env = WindingRoadEnv()
        env.reset(seed=seed)
        return [(round(s.length_m, 3), round(s.turn_rad, 4)) for s in env.segments]

    assert shape(1) == shape(1)
    assert shape(1) != shape(2)
