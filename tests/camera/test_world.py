"""The tiled world raster: consistent tiles, periodic textures, lanes from geometry."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest
from highway_env.road.lane import LineType, PolyLaneFixedWidth, SineLane, StraightLane
from highway_env.road.road import RoadNetwork

from simroad.camera import MARKING, ROADSIDE, SHOULDER, WorldRaster
from simroad.camera.codes import IS_ROAD
from simroad.errors import SimroadError


def _straight_world(rng, line_types=(LineType.CONTINUOUS, LineType.STRIPED)):
    net = RoadNetwork()
    net.add_lane("a", "b", StraightLane([0, 0], [200, 0], width=4.0, line_types=line_types))
    return WorldRaster(net, rng, texel_m=0.1)


def test_window_equals_its_tiles_and_is_reused(rng):
    w = _straight_world(rng)
    win = w.window(5.0, -10.0, 60.0, 10.0)
    T = w.tile_px
    i0, j0 = round(win.x0 / w.tile_m), round(win.y0 / w.tile_m)
    rgba, mat = w.tile(i0 + 1, j0 + 1)
    np.testing.assert_array_equal(win.rgba[T : 2 * T, T : 2 * T], rgba)
    np.testing.assert_array_equal(win.material[T : 2 * T, T : 2 * T], mat)
    assert w.window(6.0, -9.0, 59.0, 9.0) is win  # fits: no re-assembly


def test_a_dropped_world_is_freed_at_once_not_by_the_cyclic_collector(rng):
    # A world is hundreds of MB in the scenarios; a reference cycle through its windows
    # kept every reset's world alive until a full collection (RSS grew to 3 GB in 80 resets).
    w = _straight_world(rng)
    win = w.window(5.0, -10.0, 60.0, 10.0)
    level1 = win.level(1)
    gc.disable()
    try:
        ref = weakref.ref(w)
        del w
        assert ref() is None
    finally:
        gc.enable()
    np.testing.assert_array_equal(win.level(1), level1)  # levels made before stay
    with pytest.raises(SimroadError, match="world is gone"):
        win.level(2)


def test_lane_surface_texels_match_the_lane_width(rng):
    w = _straight_world(rng, line_types=(LineType.NONE, LineType.NONE))
    win = w.window(20.0, -10.0, 40.0, 10.0)
    col = int((30.0 - win.x0) / win.texel_m)
    road = IS_ROAD[win.material[:, col]].sum()
    assert road == 40  # 4.0 m / 0.1 m texels
    assert (win.material[:, col] == SHOULDER).sum() > 0
    assert (win.material[:, col] == ROADSIDE).sum() > 0


def test_striped_line_is_dashed_and_continuous_line_is_not(rng):
    w = _straight_world(rng)
    win = w.window(10.0, -5.0, 130.0, 5.0)
    mat = win.material
    rows_left = int((-2.0 + 0.05 - win.y0) / win.texel_m)  # inside the left edge
    rows_right = int((2.0 - 0.05 - win.y0) / win.texel_m)
    c0, c1 = int((20 - win.x0) / 0.1), int((120 - win.x0) / 0.1)
    left = mat[rows_left, c0:c1] == MARKING
    right = mat[rows_right, c0:c1] == MARKING
    assert left.mean() > 0.98
    assert 0.15 < right.mean() < 0.35  # 3 m dash every 12 m


def test_same_seed_same_world_and_tiles_do_not_depend_on_visit_order():
    a = _straight_world(np.random.default_rng(5))
    b = _straight_world(np.random.default_rng(5))
    a.tile(0, 0), a.tile(3, 0)
    b.tile(3, 0), b.tile(0, 0)
    for key in ((0, 0), (3, 0)):
        np.testing.assert_array_equal(a.tile(*key)[0], b.tile(*key)[0])


def test_texture_wraps_seamlessly_between_tiles(rng):
    w = _straight_world(rng)
    win = w.window(-60.0, 20.0, 60.0, 40.0)  # roadside only, across tile seams
    g = win.rgba.astype(float).mean(axis=2)
    T = w.tile_px
    seam = np.abs(g[:, T] - g[:, T - 1]).mean()
    inside = np.abs(g[:, T // 2] - g[:, T // 2 - 1]).mean()
    assert seam < 1.5 * inside + 1.0


def _sdf_agrees_with_lane(lane, rng, tol_m):
    """Texels of the world raster are road exactly where highway-env says on-lane,
    except within ``tol_m`` of the lane edge."""
    net = RoadNetwork()
    net.add_lane("a", "b", lane)
    w = WorldRaster(net, rng, texel_m=0.1)
    x0, y0, x1, y1 = w.bounds()
    win = w.window(x0, y0, x1, y1)
    pts = rng.uniform([x0, y0], [x1, y1], size=(3000, 2))
    cols = ((pts[:, 0] - win.x0) / 0.1).astype(int)
    rows = ((pts[:, 1] - win.y0) / 0.1).astype(int)
    centres = np.column_stack([win.x0 + (cols + 0.5) * 0.1, win.y0 + (rows + 0.5) * 0.1])
    road = IS_ROAD[win.material[rows, cols]]
    disagree = 0
    for p, r in zip(centres, road):
        s, lat = lane.local_coordinates(p)
        inside = 0 <= s <= lane.length and abs(lat) <= lane.width_at(s) / 2
        margin = min(abs(abs(lat) - lane.width_at(s) / 2), abs(s), abs(s - lane.length))
        if inside != r and margin > tol_m:
            disagree += 1
    return disagree


def test_sine_lane_is_rasterised_from_its_geometry(rng):
    lane = SineLane([0, 0], [120, 0], amplitude=4.0, pulsation=2 * np.pi / 60, phase=0.0, width=4.0)
    assert _sdf_agrees_with_lane(lane, rng, tol_m=0.01) == 0


def test_poly_lane_is_rasterised_from_its_outline(rng):
    xs = np.linspace(0, 100, 21)
    centre = np.column_stack([xs, 8 * np.sin(xs / 25)])
    lane = PolyLaneFixedWidth(centre.tolist(), width=4.0)
    assert _sdf_agrees_with_lane(lane, rng, tol_m=0.15) == 0  # texel-level for PolyLane


def _urban_world(rng, **kwargs):
    from simroad.camera.palette import draw_palette

    net = RoadNetwork()
    net.add_lane("a", "b", StraightLane([0, 0], [200, 0], width=4.0, line_types=(LineType.NONE, LineType.NONE)))
    palette = draw_palette(rng, roadside="grass", profile="urban")
    return WorldRaster(net, rng, texel_m=0.1, palette=palette, **kwargs), palette


def test_urban_cross_section_is_road_kerb_sidewalk_roadside(rng):
    from simroad.camera.codes import ASPHALT, KERB, SIDEWALK

    w, p = _urban_world(rng)
    win = w.window(20.0, -12.0, 40.0, 12.0)
    col = int((30.0 - win.x0) / win.texel_m)
    ys = win.y0 + (np.arange(win.material.shape[0]) + 0.5) * win.texel_m
    mat = win.material[:, col]
    d = np.abs(ys) - 2.0  # distance beyond the road edge (m)
    inner = (d > 0.06) & (d < p.kerb_width_m - 0.06)
    walk = (d > p.kerb_width_m + 0.06) & (d < p.verge_width_m - 0.06)
    assert np.all(mat[d < -0.06] == ASPHALT)
    assert np.all(mat[inner] == KERB) and np.any(mat[(d > -0.06) & (d < p.kerb_width_m + 0.06)] == KERB)
    assert np.all(mat[walk] == SIDEWALK)
    assert np.all(mat[(d > p.verge_width_m + 0.06) & (d < 8.0)] == ROADSIDE)
    assert not np.any(mat == SHOULDER)


def test_extra_markings_paint_only_the_road(rng):
    zebra = [np.array([[50.0 + k, -5.0], [50.5 + k, -5.0], [50.5 + k, 5.0], [50.0 + k, 5.0]]) for k in range(4)]
    w, _ = _urban_world(rng, extra_markings=zebra)
    win = w.window(45.0, -8.0, 60.0, 8.0)
    col = int((50.25 - win.x0) / win.texel_m)
    ys = win.y0 + (np.arange(win.material.shape[0]) + 0.5) * win.texel_m
    mat = win.material[:, col]
    assert np.all(mat[np.abs(ys) < 1.9] == MARKING)
    assert not np.any(mat[np.abs(ys) > 2.1] == MARKING)
    gap = int((50.75 - win.x0) / win.texel_m)
    assert not np.any(win.material[:, gap] == MARKING)


@pytest.mark.parametrize(
    "bad",
    [np.zeros((4, 2)), [np.zeros((2, 2))], [np.zeros((4, 3))], [[[0, 0], [1, 0], [np.nan, 1]]], ["abc"], 5],
)
def test_bad_extra_markings_are_refused_by_name(rng, bad):
    net = RoadNetwork()
    net.add_lane("a", "b", StraightLane([0, 0], [50, 0], width=4.0))
    with pytest.raises(SimroadError, match="extra_markings"):
        WorldRaster(net, rng, extra_markings=bad)
