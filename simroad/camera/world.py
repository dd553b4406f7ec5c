"""The ground-plane world raster: road, markings, shoulders or kerbs and sidewalks, roadside.

Built once per episode from highway-env's road network, using each lane's own
geometry (``lane.position(s, lateral)``), never its colours. The world is cut into
square tiles rendered lazily and cached, so a 10 km highway never needs one giant
raster; the camera asks for a window covering its view and gets a contiguous
array assembled from tiles.

Materials
---------
Every texel and pixel carries a material code (:data:`MATERIAL_NAMES`). Ground codes
are the ones a ground texel can have (:data:`GROUND_MATERIALS`); the road is
:data:`ROAD_MATERIALS` (asphalt and its markings). Scenery and vehicles have codes of
their own, so the camera's ``material`` map tells every visible thing apart.
"""

from __future__ import annotations

import math
import weakref
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np
from highway_env.road.lane import CircularLane, StraightLane

from simroad.camera._tile_kernel import compose_tile
from simroad.camera.codes import (  # re-exported: importers of simroad.camera.world keep working
    ASPHALT,
    KERB,
    MARKING,
    ROADSIDE,
    SHOULDER,
    SIDEWALK,
)
from simroad.camera.mesh import Mesh
from simroad.camera.palette import Palette, draw_palette
from simroad.camera.textures import ground_textures, wear_factor
from simroad.camera.window import Window  # re-exported: importers of simroad.camera.world keep working
from simroad.core.lanes import lane_positions, lane_signed_distance, supports_vectorised
from simroad.errors import InvalidParameterError, SimroadError

__all__ = [
    "LaneShape",
    "SceneryLike",
    "WorldRaster",
    "lane_shapes",
]


MARKING_WIDTH_M = 0.15
DASH_LENGTH_M = 3.0
DASH_PERIOD_M = 12.0
_TEX_SIZE = 512
_WEAR_RES = 20  # wear lookup steps per metre of distance to the lane edge
_WEAR_STEPS = 80
_SHIFT = 4  # fixed-point bits for cv2.fillPoly
_SCALE = 1 << _SHIFT


def _overlaps(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] <= b[2] and a[2] >= b[0] and a[1] <= b[3] and a[3] >= b[1]


def _check_polygons(name: str, polys: object) -> list[np.ndarray]:
    """Validate a sequence of world polygons, each (N >= 3, 2) finite metres."""
    if isinstance(polys, np.ndarray) or not isinstance(polys, Sequence):
        raise InvalidParameterError(
            f"{name}: expected a sequence (list or tuple) of (N, 2) polygon arrays, got {type(polys).__name__}. "
            "Wrap a single polygon in a list."
        )
    out = []
    for k, p in enumerate(polys):
        try:
            a = np.asarray(p, dtype=float) if not isinstance(p, str) else np.zeros(0)
        except (TypeError, ValueError):
            a = np.zeros(0)
        if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] < 3:
            raise InvalidParameterError(
                f"{name}[{k}]: expected a polygon of shape (N, 2) with N >= 3 world points (m), got shape {a.shape}."
            )
        if not np.all(np.isfinite(a)):
            raise InvalidParameterError(f"{name}[{k}]: expected finite coordinates, got NaN or infinity.")
        out.append(a)
    return out


@dataclass
class LaneShape:
    """A lane and its rasterisable outline in world coordinates."""

    lane: object  # the highway-env lane
    surface: np.ndarray  # (N, 2) polygon of the drivable lane surface
    markings: list[np.ndarray]  # polygons of painted lines, inside the lane
    bbox: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax incl. shoulder


def _sample_s(lane) -> np.ndarray:
    length = float(lane.length)
    if type(lane).__name__ == "StraightLane":
        return np.array([0.0, length])
    n = max(2, int(math.ceil(length / 1.0)) + 1)
    return np.linspace(0.0, length, n)


def _edge(lane, s: np.ndarray, lat: np.ndarray | float) -> np.ndarray:
    """``lane.position(s_i, lat_i)`` for every sample, (N, 2) (straight and circular lanes
    at once: :func:`simroad.core.lanes.lane_positions`)."""
    lat = np.broadcast_to(np.asarray(lat, dtype=float), s.shape)
    if type(lane) in (StraightLane, CircularLane):
        return lane_positions(lane, s, lat)
    return np.array([lane.position(float(si), float(li)) for si, li in zip(s, lat)])


def _band(lane, s: np.ndarray, lat_a, lat_b) -> np.ndarray:
    a = _edge(lane, s, lat_a)
    b = _edge(lane, s, lat_b)
    return np.vstack([a, b[::-1]])


def _dash_ranges(length: float) -> list[tuple[float, float]]:
    out = []
    start = 0.0
    while start < length:
        out.append((start, min(start + DASH_LENGTH_M, length)))
        start += DASH_PERIOD_M
    return out


def lane_shapes(network, shoulder_width_m: float) -> list[LaneShape]:
    """Outline every lane of a highway-env ``RoadNetwork``."""
    shapes = []
    for lane in network.lanes_list():
        s = _sample_s(lane)
        half = np.array([lane.width_at(float(si)) / 2.0 for si in s])
        surface = _band(lane, s, -half, half)
        markings = []
        line_types = lane.line_types or (0, 0)
        for side, kind in enumerate(line_types):
            if kind == 0:  # LineType.NONE
                continue
            sign = -1.0 if side == 0 else 1.0
            ranges = [(0.0, float(lane.length))] if kind != 1 else _dash_ranges(float(lane.length))
            for s0, s1 in ranges:
                if s1 - s0 < 1e-3:
                    continue
                n = 2 if type(lane).__name__ == "StraightLane" else max(2, int(math.ceil((s1 - s0) / 0.5)) + 1)
                ss = np.linspace(s0, s1, n)
                hw = np.array([lane.width_at(float(si)) / 2.0 for si in ss])
                markings.append(_band(lane, ss, sign * hw, sign * (hw - MARKING_WIDTH_M)))
        lo = surface.min(axis=0) - shoulder_width_m
        hi = surface.max(axis=0) + shoulder_width_m
        shapes.append(LaneShape(lane, surface, markings, (lo[0], lo[1], hi[0], hi[1])))
    return shapes


class SceneryLike(Protocol):
    """What :attr:`WorldRaster.scenery` holds: anything that returns its faces in a box."""

    def meshes(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Mesh: ...


class WorldRaster:
    """Lazily tiled ground raster of a road network.

    Parameters
    ----------
    network : highway_env.road.road.RoadNetwork
        The road network to draw.
    rng : numpy.random.Generator
        Draws the palette and textures.
    texel_m : float
        Texel size in metres.
    palette : Palette, optional
        Fixed colours; drawn from ``rng`` when omitted.
    tile_px : int
        Tile side in texels.
    max_tiles : int
        Size of the tile cache.
    extra_markings : sequence of ndarray (N, 2)
        World polygons (m) painted as :data:`MARKING` where they lie on the road:
        zebra crossings, stop lines. Paint off the road is ignored.
    """

    def __init__(
        self,
        network,
        rng: np.random.Generator,
        *,
        texel_m: float = 0.1,
        palette: Palette | None = None,
        tile_px: int = 256,
        max_tiles: int = 400,
        extra_markings: Sequence[np.ndarray] = (),
    ) -> None:
        self.texel_m = float(texel_m)
        self.tile_px = int(tile_px)
        self.max_tiles = int(max_tiles)
        self.extra_markings = _check_polygons("extra_markings", extra_markings)
        self._extra_bbox = [(*m.min(axis=0), *m.max(axis=0)) for m in self.extra_markings]
        self.palette = palette or draw_palette(rng)
        self.shapes = lane_shapes(network, self.palette.verge_width_m)
        self._marking_bbox = {id(s): [(*m.min(axis=0), *m.max(axis=0)) for m in s.markings] for s in self.shapes}
        codes = {"roadside": ROADSIDE, "shoulder": SHOULDER, "asphalt": ASPHALT, "marking": MARKING}
        codes |= {"kerb": KERB, "sidewalk": SIDEWALK}
        tex = ground_textures(self.palette, _TEX_SIZE, self.texel_m, rng)
        self._tex = {codes[name]: t for name, t in tex.items()}
        slot = np.full(256, -1, dtype=np.int64)  # material code -> its texture in the stack
        slot[list(self._tex)] = np.arange(len(self._tex))
        self._textures = (np.stack(list(self._tex.values())), slot)
        self._wear_lut = wear_factor(np.arange(_WEAR_STEPS, dtype=np.float32) / _WEAR_RES, self.palette.asphalt_age)
        self._tiles: OrderedDict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = OrderedDict()
        self._tile_levels: OrderedDict[tuple[int, int, int], np.ndarray] = OrderedDict()
        self._windows: dict[str, Window] = {}
        #: What stands on the ground (trees, poles, buildings, ...): any object with
        #: ``meshes(xmin, ymin, xmax, ymax) -> Mesh``; ``None`` for a bare world.
        self.scenery: SceneryLike | None = None

    def objects(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Mesh:
        """The scenery faces that may lie in the world box (metres)."""
        if self.scenery is None:
            return Mesh.empty()
        return self.scenery.meshes(xmin, ymin, xmax, ymax)

    # ----------------------------------------------------------------- tiles
    @property
    def tile_m(self) -> float:
        return self.tile_px * self.texel_m

    def tile(self, i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Return (rgba, material) of tile column ``i``, row ``j`` (cached)."""
        key = (i, j)
        hit = self._tiles.get(key)
        if hit is not None:
            self._tiles.move_to_end(key)
            return hit
        out = self._render_tile(i, j)
        self._tiles[key] = out
        if len(self._tiles) > self.max_tiles:
            self._tiles.popitem(last=False)
        return out

    def _render_tile(self, i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        T, _t = self.tile_px, self.texel_m
        x0, y0 = i * self.tile_m, j * self.tile_m
        x1, y1 = x0 + self.tile_m, y0 + self.tile_m
        visible = [
            s for s in self.shapes if s.bbox[0] <= x1 and s.bbox[2] >= x0 and s.bbox[1] <= y1 and s.bbox[3] >= y0
        ]
        sdf = self._tile_sdf(visible, x0, y0)
        material = self._bands(sdf)
        paint = np.zeros((T, T), dtype=np.uint8)
        cover = np.zeros((T, T), dtype=np.uint8)  # anti-aliased paint coverage, for the colour only
        # A lane's markings run along all of it: only those near the tile can touch it
        # (two texels of margin hold the anti-aliased edge).
        near = (x0 - 2 * _t, y0 - 2 * _t, x1 + 2 * _t, y1 + 2 * _t)
        polys = [m for s in visible for m, b in zip(s.markings, self._marking_bbox[id(s)]) if _overlaps(b, near)]
        polys += [m for m, b in zip(self.extra_markings, self._extra_bbox) if _overlaps(b, (x0, y0, x1, y1))]
        for m in polys:
            pts = [self._fixed(m, x0, y0)]
            cv2.fillPoly(paint, pts, 1, lineType=cv2.LINE_8, shift=_SHIFT)
            cv2.fillPoly(cover, pts, 255, lineType=cv2.LINE_AA, shift=_SHIFT)
        ti, tj = (j * T) % _TEX_SIZE, (i * T) % _TEX_SIZE
        rgba = np.empty((T, T, 4), dtype=np.uint8)
        compose_tile(material, sdf, paint, cover, *self._textures, ti, tj, self._wear_lut, _WEAR_RES, rgba)
        return rgba, material

    def _bands(self, sdf: np.ndarray) -> np.ndarray:
        """Ground material of every texel from its signed distance to the road (m)."""
        p = self.palette
        material = np.full(sdf.shape, ROADSIDE, dtype=np.uint8)
        if p.profile == "urban":
            material[sdf >= -(p.kerb_width_m + p.sidewalk_width_m)] = SIDEWALK
            material[sdf >= -p.kerb_width_m] = KERB
        else:
            material[sdf >= -p.shoulder_width_m] = SHOULDER
        material[sdf >= 0.0] = ASPHALT
        return material

    def _fixed(self, poly: np.ndarray, x0: float, y0: float) -> np.ndarray:
        pts = (poly - (x0, y0)) / self.texel_m - 0.5
        return np.round(pts * _SCALE).astype(np.int32)

    def _tile_sdf(self, visible: list[LaneShape], x0: float, y0: float) -> np.ndarray:
        """Signed distance (m) to the union of lane surfaces at every texel centre."""
        T, t = self.tile_px, self.texel_m
        sdf = np.full((T, T), -1e3, dtype=np.float32)
        xs = x0 + (np.arange(T) + 0.5) * t
        ys = y0 + (np.arange(T) + 0.5) * t
        for s in visible:
            c0 = max(0, int((s.bbox[0] - x0) / t) - 1)
            c1 = min(T, int(np.ceil((s.bbox[2] - x0) / t)) + 1)
            r0 = max(0, int((s.bbox[1] - y0) / t) - 1)
            r1 = min(T, int(np.ceil((s.bbox[3] - y0) / t)) + 1)
            if c1 <= c0 or r1 <= r0:
                continue
            if supports_vectorised(s.lane):
                X, Y = np.meshgrid(xs[c0:c1], ys[r0:r1])
                d = lane_signed_distance(s.lane, X, Y)
            else:  # e.g. PolyLane: distance transform of the rasterised polygon
                d = self._polygon_sdf(s.surface, x0, y0)[r0:r1, c0:c1]
            np.maximum(sdf[r0:r1, c0:c1], d, out=sdf[r0:r1, c0:c1])
        return sdf

    def _polygon_sdf(self, poly: np.ndarray, x0: float, y0: float) -> np.ndarray:
        T, t = self.tile_px, self.texel_m
        inside = np.zeros((T, T), dtype=np.uint8)
        cv2.fillPoly(inside, [self._fixed(poly, x0, y0)], 1, lineType=cv2.LINE_8, shift=_SHIFT)
        d_in = cv2.distanceTransform(inside, cv2.DIST_L2, 5)
        d_out = cv2.distanceTransform(1 - inside, cv2.DIST_L2, 5)
        return ((d_in - d_out) * t).astype(np.float32)

    # ---------------------------------------------------------------- window
    def window(
        self,
        xmin: float,
        ymin: float,
        xmax: float,
        ymax: float,
        *,
        slot: str = "camera",
        lead: tuple[float, float] = (0.0, 0.0),
    ) -> Window:
        """A contiguous window covering the world box (metres), reused while it fits.

        Each ``slot`` (the camera view, the bird's-eye view, ...) keeps its own window.
        A new window has one tile of slack on every side and reaches ``lead`` (metres,
        world x and y) farther in that direction: a camera moving forward passes the
        lead before the window is assembled again.
        """
        w = self._windows.get(slot)
        if w is not None and w.contains(xmin, ymin, xmax, ymax):
            return w
        tm = self.tile_m
        lx, ly = float(lead[0]), float(lead[1])
        # One tile of slack on every side, so small moves reuse the window.
        i0, i1 = math.floor((xmin + min(lx, 0.0)) / tm) - 1, math.floor((xmax + max(lx, 0.0)) / tm) + 1
        j0, j1 = math.floor((ymin + min(ly, 0.0)) / tm) - 1, math.floor((ymax + max(ly, 0.0)) / tm) + 1
        rgba, material = self._assemble(i0, i1, j0, j1, 0)

        # The window is kept by this world: a weak reference back, not a cycle that would
        # hold the whole world (hundreds of MB) until the cyclic garbage collector ran.
        world = weakref.ref(self)

        def level_source(k: int) -> np.ndarray:
            raster = world()
            if raster is None:
                raise SimroadError("this window's world is gone: keep the WorldRaster while its windows are in use.")
            return raster._assemble(i0, i1, j0, j1, k)[0]

        self._windows[slot] = Window(rgba, material, i0 * tm, j0 * tm, self.texel_m, level_source)
        return self._windows[slot]

    def _assemble(self, i0: int, i1: int, j0: int, j1: int, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Colour (mip level ``k``) and, at level 0, material of tiles ``i0..i1`` x ``j0..j1``."""
        T = self.tile_px >> k
        nx, ny = i1 - i0 + 1, j1 - j0 + 1
        rgba = np.empty((ny * T, nx * T, 4), dtype=np.uint8)
        material = np.empty((ny * T, nx * T) if k == 0 else (0, 0), dtype=np.uint8)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                r, c = (j - j0) * T, (i - i0) * T
                if k == 0:
                    trgba, tmat = self.tile(i, j)
                    material[r : r + T, c : c + T] = tmat
                else:
                    trgba = self.tile_level(i, j, k)
                rgba[r : r + T, c : c + T] = trgba
        return rgba, material

    def tile_level(self, i: int, j: int, k: int) -> np.ndarray:
        """Mip level ``k`` >= 1 of tile (``i``, ``j``)'s colour: ``cv2.pyrDown`` of level
        ``k - 1`` (cached with the tile; at a tile's edge the filter reflects, a
        difference of a fraction of a far, sub-pixel texel)."""
        key = (i, j, k)
        hit = self._tile_levels.get(key)
        if hit is not None:
            return hit
        below = self.tile(i, j)[0] if k == 1 else self.tile_level(i, j, k - 1)
        out = cv2.pyrDown(below)
        self._tile_levels[key] = out
        if len(self._tile_levels) > 3 * self.max_tiles:
            self._tile_levels.popitem(last=False)
        return out

    def bounds(self) -> tuple[float, float, float, float]:
        """World bounding box (xmin, ymin, xmax, ymax) of all lanes and shoulders."""
        b = np.array([s.bbox for s in self.shapes])
        return float(b[:, 0].min()), float(b[:, 1].min()), float(b[:, 2].max()), float(b[:, 3].max())
