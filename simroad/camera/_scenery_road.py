"""Where scenery may stand: distances to the road and the road's edge lines.

:class:`RoadIndex` answers the placement questions of :mod:`simroad.camera.scenery`
from the lanes' own geometry (``WorldRaster.shapes``): the distance of any point to
the nearest lane surface, and the *edge lines* -- every lane edge sampled every few
metres with its heading and outward normal -- along which guard rails, walls, lamp
posts and facades are laid out. Edge samples are bucketed by world cell, so a cell
finds its own in constant time; their ``outer`` flag (nothing but roadside beyond
the shoulder) is computed lazily per cell.
"""

from __future__ import annotations

import math
from collections import defaultdict

import cv2
import numpy as np
from highway_env.road.lane import CircularLane, SineLane, StraightLane

from simroad.core.lanes import lane_signed_distance, supports_vectorised

__all__ = ["EDGE_STEP_M", "RoadIndex", "lane_positions"]

#: Spacing of the edge-line samples along each lane, m.
EDGE_STEP_M = 4.0
_STRAIGHT_HALF_M = 6.0  # road + shoulders of the default straight road (no shapes)


def lane_positions(lane, s: np.ndarray, lat: np.ndarray | float) -> np.ndarray:
    """World (x, y) of lane coordinates ``(s, lat)``, (N, 2), vectorised where exact."""
    s = np.asarray(s, dtype=float)
    lat_a: np.ndarray = np.broadcast_to(np.asarray(lat, dtype=float), s.shape)
    if type(lane) is StraightLane:
        return lane.start + s[:, None] * lane.direction + lat_a[:, None] * lane.direction_lateral
    if type(lane) is CircularLane:
        phi = lane.direction * s / lane.radius + lane.start_phase
        r = lane.radius - lat_a * lane.direction
        return lane.center + r[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    if type(lane) is SineLane:
        lat_a = lat_a + lane.amplitude * np.sin(lane.pulsation * s + lane.phase)
        return lane.start + s[:, None] * lane.direction + lat_a[:, None] * lane.direction_lateral
    return np.array([lane.position(float(a), float(b)) for a, b in zip(s, lat_a)]).reshape(-1, 2)


class RoadIndex:
    """Lane geometry for placing scenery.

    Parameters
    ----------
    shapes : list of LaneShape or None
        ``WorldRaster.shapes``; ``None`` is a straight road along world x with
        road and shoulders within 6 m of y = 0 (for tests and examples).
    cell_m : float
        Side of the world cells edge samples are bucketed by, m.
    """

    def __init__(self, shapes, cell_m: float) -> None:
        self.cell_m = float(cell_m)
        self.lanes = [s.lane for s in shapes] if shapes is not None else []
        self.straight = shapes is None
        boxes = []
        for sh in shapes or []:
            surf = np.asarray(sh.surface, dtype=float)
            boxes.append((*surf.min(axis=0), *surf.max(axis=0)))
        self.bboxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        self._contours = [np.asarray(s.surface, np.float32).reshape(-1, 1, 2) for s in shapes or []]
        self._edges()

    # ------------------------------------------------------------ distances
    def distance(self, pts: np.ndarray, reach: float = 60.0) -> np.ndarray:
        """Distance (m) from points (N, 2) to the nearest lane surface: < 0 inside a
        lane, ``reach`` when no lane is within ``reach``."""
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        if self.straight:
            return np.abs(pts[:, 1]) - (_STRAIGHT_HALF_M - 1.0)
        out = np.full(len(pts), -float(reach))  # holds -distance (the signed field)
        if not len(pts):
            return -out
        lo, hi = pts.min(axis=0) - reach, pts.max(axis=0) + reach
        b = self.bboxes
        near = np.flatnonzero((b[:, 0] <= hi[0]) & (b[:, 2] >= lo[0]) & (b[:, 1] <= hi[1]) & (b[:, 3] >= lo[1]))
        for k in near:
            lane = self.lanes[k]
            if supports_vectorised(lane):
                d = lane_signed_distance(lane, pts[:, 0], pts[:, 1])
            else:
                c = self._contours[k]
                d = np.array([cv2.pointPolygonTest(c, (float(x), float(y)), True) for x, y in pts])
            np.maximum(out, d, out=out)
        return -out

    # ---------------------------------------------------------- edge lines
    def _edges(self) -> None:
        """Sample both edges of every lane every ``EDGE_STEP_M`` and bucket by cell."""
        recs: list[np.ndarray] = []
        if self.straight:
            s = np.arange(-5000.0, 5000.0, EDGE_STEP_M)
            for side in (-1, 1):
                base = np.column_stack([s, np.full_like(s, side * (_STRAIGHT_HALF_M - 1.0))])
                recs.append(self._records(0, side, s, base, np.zeros_like(s), side, 0, 0.0))
        chain, offset = self._chains()
        self._chain_of = {}  # chain -> (start offsets, lane indices), sorted by offset
        for root in sorted(set(chain)):
            ks = sorted((offset[k], k) for k in range(len(self.lanes)) if chain[k] == root)
            self._chain_of[root] = (np.array([o for o, _ in ks]), [k for _, k in ks])
        self._step = [float(lane.length) / (max(2, int(math.ceil(float(lane.length) / EDGE_STEP_M)) + 1) - 1)
                      for lane in self.lanes]  # fmt: skip
        for k, lane in enumerate(self.lanes):
            n = max(2, int(math.ceil(float(lane.length) / EDGE_STEP_M)) + 1)
            s = np.linspace(0.0, float(lane.length), n)
            half = float(lane.width_at(0.0)) / 2.0
            centre = lane_positions(lane, s, 0.0)
            ahead = lane_positions(lane, np.minimum(s + 0.5, float(lane.length) + 0.5), 0.0)
            heading = np.arctan2(ahead[:, 1] - centre[:, 1], ahead[:, 0] - centre[:, 0])
            for side in (-1, 1):
                base = lane_positions(lane, s, side * half)
                recs.append(self._records(k, side, s, base, heading, side, chain[k], offset[k]))
        self.edge = np.concatenate(recs) if recs else np.zeros((0, 10))
        cells = np.floor(self.edge[:, 3:5] / self.cell_m).astype(np.int64)
        self._bucket: dict[tuple[int, int], np.ndarray] = {}
        groups: dict[tuple[int, int], list[int]] = defaultdict(list)
        for idx, (i, j) in enumerate(cells.tolist()):
            groups[(i, j)].append(idx)
        self._bucket = {key: np.asarray(v) for key, v in groups.items()}

    def _chains(self) -> tuple[list[int], list[float]]:
        """Lanes that continue one another (a lane starting where an earlier one ends,
        in the same direction) form a chain: its root lane and the arc length at
        which each lane starts along it, m."""
        root, offset = list(range(len(self.lanes))), [0.0] * len(self.lanes)
        ends: list[tuple[np.ndarray, np.ndarray]] = []
        for k, lane in enumerate(self.lanes):
            start = lane_positions(lane, np.array([0.0, 0.5]), 0.0)
            for q, (end, end_dir) in enumerate(ends):
                d0 = start[1] - start[0]
                if np.hypot(*(start[0] - end)) < 0.5 and float(d0 @ end_dir) > 0.45:
                    root[k], offset[k] = root[q], offset[q] + float(self.lanes[q].length)
                    break
            e = lane_positions(lane, np.array([float(lane.length) - 0.5, float(lane.length)]), 0.0)
            ends.append((e[1], e[1] - e[0]))
        return root, offset

    @staticmethod
    def _records(lane: int, side: int, s, base, heading, sign, chain: int, offset: float) -> np.ndarray:
        """Rows: lane, side, s, x, y, heading, normal x, normal y (outward, away from
        the lane centre; ``side`` -1 is the lane's left in highway-env's lateral),
        chain (root lane), arc length along the chain."""
        h = np.asarray(heading, dtype=float)
        lat = np.column_stack([-np.sin(h), np.cos(h)])  # highway-env's +lateral
        normal = lat * sign
        n = len(s)
        return np.column_stack([np.full(n, lane), np.full(n, side), s, base, h, normal, np.full(n, chain), s + offset])

    def edge_samples(self, i: int, j: int, offset_m: float) -> np.ndarray:
        """Edge samples of cell (i, j) whose point ``offset_m`` beyond the edge (along
        the outward normal) lies outside every lane by at least ``offset_m - 0.3``:
        the road's outer edges there. Rows as :meth:`_records`, sorted by lane,
        side and s."""
        idx = self._bucket.get((i, j))
        if idx is None:
            return np.zeros((0, 10))
        e = self.edge[idx]
        probe = e[:, 3:5] + offset_m * e[:, 6:8]
        keep = self.distance(probe, reach=offset_m + 10.0) >= offset_m - 0.3
        e = e[keep]
        return e[np.lexsort((e[:, 2], e[:, 1], e[:, 0]))]

    def step(self, k: int) -> float:
        """Spacing (m) of lane ``k``'s edge samples (at most :data:`EDGE_STEP_M`)."""
        return self._step[k] if self.lanes else EDGE_STEP_M

    def chain_end(self, chain: int) -> float:
        """Arc length (m) at which ``chain`` ends (infinite for the straight road)."""
        if not self.lanes:
            return math.inf
        offsets, ks = self._chain_of[chain]
        return float(offsets[-1]) + float(self.lanes[ks[-1]].length)

    def chain_points(self, chain: int, side: int, sg, off: float) -> tuple[np.ndarray, np.ndarray]:
        """Points ``off`` m beyond the ``side`` edge of ``chain`` at arc lengths ``sg``
        (N,) along it (clamped to the chain), and the outward normals there, (N, 2)
        each. Edge samples of the same chain and side lie on these lines."""
        sg = np.atleast_1d(np.asarray(sg, dtype=float))
        if not self.lanes:
            xy = np.column_stack([sg, np.full(len(sg), side * (_STRAIGHT_HALF_M - 1.0 + off))])
            return xy, np.tile([0.0, float(side)], (len(sg), 1))
        offsets, ks = self._chain_of[chain]
        idx = np.clip(np.searchsorted(offsets, sg, side="right") - 1, 0, len(ks) - 1)
        xy, nrm = np.empty((len(sg), 2)), np.empty((len(sg), 2))
        for q in np.unique(idx).tolist():
            sel = idx == q
            lane = self.lanes[ks[q]]
            s = np.clip(sg[sel] - offsets[q], 0.0, float(lane.length))
            half = float(lane.width_at(0.0)) / 2.0
            xy[sel] = lane_positions(lane, s, side * (half + off))
            a = lane_positions(lane, s, 0.0)
            b = lane_positions(lane, s + 0.5, 0.0)
            h = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
            nrm[sel] = np.column_stack([-np.sin(h), np.cos(h)]) * side
        return xy, nrm

    def polyline(
        self, chain: int, side: int, t0: float, t1: float, off: float, tol: float = 0.05
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The line ``off`` m beyond an edge from arc length ``t0`` to ``t1`` as 1, 2
        or 4 straight pieces, the fewest that stay within ``tol`` m of it: points and
        outward normals (K, 2), arc lengths (K,)."""
        ts = np.linspace(t0, t1, 5)
        pts, nrm = self.chain_points(chain, side, ts, off)

        def dev(a: int, c: int, mids: list[int]) -> float:
            d = pts[c] - pts[a]
            v = pts[mids] - pts[a]
            return float(np.abs(d[0] * v[:, 1] - d[1] * v[:, 0]).max() / max(float(np.hypot(*d)), 1e-9))

        if dev(0, 4, [1, 2, 3]) < tol:
            idx = [0, 4]
        elif max(dev(0, 2, [1]), dev(2, 4, [3])) < tol:
            idx = [0, 2, 4]
        else:
            idx = [0, 1, 2, 3, 4]
        return pts[idx], nrm[idx], ts[idx]

    def lane_length(self, k: int) -> float:
        """Length of lane ``k`` (m; infinite for the default straight road)."""
        return float(self.lanes[k].length) if self.lanes else math.inf

    def nearest(self, pt: np.ndarray) -> tuple[float, np.ndarray] | None:
        """Heading (rad) and outward normal (2,) of the edge sample nearest to ``pt``
        within about one cell; None if there is none."""
        i, j = (int(v) for v in np.floor(np.asarray(pt) / self.cell_m))
        idx = [self._bucket[k] for k in ((i + a, j + b) for a in (-1, 0, 1) for b in (-1, 0, 1)) if k in self._bucket]
        if not idx:
            return None
        e = self.edge[np.concatenate(idx)]
        k = int(np.argmin(np.hypot(e[:, 3] - pt[0], e[:, 4] - pt[1])))
        return float(e[k, 5]), e[k, 6:8]

    def cross_extent(self, centre: np.ndarray, normal: np.ndarray, margin: float, reach: float = 45.0):
        """The interval ``[t0, t1]`` of ``centre + t * normal`` (t in m) within
        ``margin`` of the road around ``t = 0``; None if the interval is not closed
        within ``reach``."""
        t = np.arange(-reach, reach + 0.01, 0.5)
        near = self.distance(centre + t[:, None] * normal, reach=margin + 5.0) < margin
        mid = len(t) // 2
        if not near[mid] or near[0] or near[-1]:
            return None
        lo = mid - np.argmin(near[mid::-1])
        hi = mid + np.argmin(near[mid:])
        return float(t[lo]), float(t[hi])
