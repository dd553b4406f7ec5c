"""Perception of the ego lane from a road mask: road edges and path on look-ahead rows.

The camera is fixed to the car and the ground is flat, so every image row below the
horizon is a line of constant forward distance on the ground: inverse perspective
mapping of the mask is a per-row lookup of the camera's constant ego-frame ground map.

Per look-ahead row :class:`LaneEstimator` finds the road run the car is on, its right
(and left) edge in metres, and the centre of the ego's lane (offset from the right
edge by lane widths; the road centre when no edge is seen). A quadratic fitted through
those centres is the path (:class:`PathEstimate`); the control law that follows it is
:mod:`simroad.control.lane_keeping`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simroad.camera.geometry import PinholeCamera
from simroad.control.config import ControllerConfig
from simroad.core.validation import check_mask
from simroad.errors import InvalidParameterError

__all__ = ["LaneEstimator", "PathEstimate"]

#: Slack (m) added to ``free_road_max_m`` so that ``np.arange`` includes it as a row.
_ARANGE_SLACK_M = 1e-6
#: Smallest forward spacing (m) of two rows when extrapolating an edge (guards 0/0).
_MIN_ROW_SPACING_M = 1e-6
#: Edge points needed for a quadratic edge slope (a line from 2, zero slope below).
_EDGE_QUADRATIC_MIN_POINTS = 4
#: The defaults of the private helpers below (they are ControllerConfig's).
_DEFAULTS = ControllerConfig()


@dataclass
class PathEstimate:
    """What the controller read off one mask (ego frame: X forward, Y right, metres)."""

    x_m: np.ndarray  # look-ahead distances with a measurement
    centre_y_m: np.ndarray  # ego-lane centre at those distances
    right_y_m: np.ndarray  # right road edge (NaN where not seen)
    left_y_m: np.ndarray  # left road edge (NaN where not seen)
    free_road_m: float  # farthest look-ahead up to which the road, and the car's corridor on it, is free
    coeffs: np.ndarray = field(default_factory=lambda: np.zeros(3))  # path Y(X), highest power first


def _check_camera_and_config(camera: Any, config: Any) -> None:
    """Refuse a camera that is not a PinholeCamera and a config that is not a ControllerConfig."""
    if not isinstance(camera, PinholeCamera):
        raise InvalidParameterError(f"camera: expected a PinholeCamera (env.camera), got {type(camera).__name__}.")
    if config is not None and not isinstance(config, ControllerConfig):
        raise InvalidParameterError(f"config: expected a ControllerConfig or None, got {type(config).__name__}.")


class LaneEstimator:
    """Read the road edges and the ego-lane path off bool road masks of one camera.

    It remembers, across the frames of an episode, the ego's lane index (counted
    from the right road edge), the number of lanes, and the last path it was told
    about (:meth:`remember`), which steers the reading of the next frame.

    Parameters
    ----------
    camera : PinholeCamera
        The calibrated camera that produced the masks (its mounting only).
    config : ControllerConfig
    """

    def __init__(self, camera: PinholeCamera, config: ControllerConfig | None = None) -> None:
        _check_camera_and_config(camera, config)
        self.camera = camera
        self.config = c = config or ControllerConfig()
        ground = camera.ego_ground
        x_col = ground[:, camera.config.width // 2, 0]
        rows, xs = _rows_at(x_col, c.lookaheads_m, c.row_match_tolerance, below_row=camera.config.height)
        if len(rows) < 2:
            raise InvalidParameterError(
                "camera: too few image rows see the look-ahead distances; lower the pitch or the look-aheads."
            )
        self._rows = np.asarray(rows)
        self._x = np.asarray(xs)
        self._row_y = ground[self._rows, :, 1]  # (n_rows, W) lateral position of each column
        # Rows beyond the path look-aheads, every free_road_step_m, only to measure free road.
        far = np.arange(self._x[-1] + c.free_road_step_m, c.free_road_max_m + _ARANGE_SLACK_M, c.free_road_step_m)
        free_rows, free_x = _rows_at(x_col, far, c.row_match_tolerance, below_row=int(self._rows[-1]))
        # Every row the car's corridor is checked on, near to far.
        self._check_rows = list(self._rows) + free_rows
        self._check_x = list(self._x) + free_x
        self._check_y = ground[self._check_rows, :, 1]
        self.reset()

    def reset(self) -> None:
        """Forget the lane index and the previous path (call at episode start)."""
        self.lane_from_right: int | None = None
        self.lanes: int | None = None
        self._prev_coeffs: np.ndarray | None = None
        self._misses = 0

    def remember(self, est: PathEstimate) -> None:
        """Take ``est`` as the previous frame's path when reading the next mask."""
        self._prev_coeffs = est.coeffs

    def read_path(self, mask: np.ndarray) -> PathEstimate:
        """Measure road edges on the look-ahead rows and the ego-lane centre line.

        A track with a validation gate: centre points farther than ``path_jump_max_m``
        from the previous path are not the lane (a misread frame, a junction's mouth).
        When none is left, the previous path is held (no points, no free road: the
        car brakes) for up to ``coast_frames`` frames; after that the path is read
        from the mask alone, as at the start (one bad frame must not lock the car on
        a wrong path for the rest of the episode).
        """
        mask = check_mask("mask", mask, shape=(self.camera.config.height, self.camera.config.width))
        est = self._read(mask)
        prior = self._prev_coeffs
        if prior is None or (len(est.x_m) and self._within_gate(est.coeffs, prior)):
            self._misses = 0
            return est
        est = PathEstimate(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), 0.0, prior)
        self._misses += 1
        if self._misses <= self.config.coast_frames:
            return est
        self._misses = 0
        self._prev_coeffs = None  # re-acquire
        return self._read(mask)

    def _within_gate(self, coeffs: np.ndarray, prior: np.ndarray) -> bool:
        """Whether the path at the nearest look-ahead row is within ``path_jump_max_m``
        of the previous path (centre points only far ahead can fit a path that is
        wrong at the car)."""
        x0 = float(self._x[0])
        return abs(float(np.polyval(coeffs, x0) - np.polyval(prior, x0))) <= self.config.path_jump_max_m

    def _read(self, mask: np.ndarray) -> PathEstimate:
        W = mask.shape[1]
        xs: list[float] = []
        rights: list[float] = []
        lefts: list[float] = []
        free = 0.0
        for k, r in enumerate(self._rows):
            yrow = self._row_y[k]
            expect = 0.0 if self._prev_coeffs is None else float(np.polyval(self._prev_coeffs, self._x[k]))
            run = _pick_run(
                mask[r], yrow, expect, max_gap_m=self.config.bridge_gap_m, max_offset_m=self.config.max_run_offset_m
            )
            if run is None:
                if rights and not (np.isfinite(rights[-1]) and np.isfinite(lefts[-1])):
                    free = self.config.free_road_max_m  # it left the view sideways: it goes on
                break  # the road ends (or is lost) here: nothing farther counts
            a, b = run
            free = self._x[k]
            xs.append(self._x[k])
            rights.append(float(yrow[b]) if b < W - 1 else math.nan)
            lefts.append(float(yrow[a]) if a > 0 else math.nan)
        x = np.asarray(xs)
        shape = self._prev_coeffs
        tol = {"tol_m": self.config.occlusion_tolerance_m, "tol_per_m": self.config.occlusion_tolerance_per_m}
        right = _occlusion_free(x, np.asarray(rights), -1.0, shape, **tol)
        left = _occlusion_free(x, np.asarray(lefts), 1.0, shape, **tol)
        cx, cy = self._centre_points(x, right, left)
        if free >= self._x[-1]:
            free = self.config.free_road_max_m  # the road goes on: the corridor says how far
        est = PathEstimate(cx, cy, right, left, float(free))
        est.coeffs = self._fit(est)
        est.free_road_m = min(est.free_road_m, self._corridor_free(mask, est))
        return est

    def _corridor_free(self, mask: np.ndarray, est: PathEstimate) -> float:
        """Farthest look-ahead up to which the car's own corridor along the path is road.

        The road run beside a car ahead in the ego's lane goes on, so the road edges alone
        do not see it; the corridor (``corridor_half_width_m`` either side of the path,
        continued straight beyond the measured rows) does: a car is not road.
        """
        c = self.config
        x_end = float(est.x_m.max()) if len(est.x_m) else float(self._x[-1])
        y_end = float(np.polyval(est.coeffs, x_end))
        slope = float(np.polyval(np.polyder(est.coeffs), x_end))
        free = 0.0
        for r, x, yrow in zip(self._check_rows, self._check_x, self._check_y):
            centre = float(np.polyval(est.coeffs, x)) if x <= x_end else y_end + slope * (x - x_end)
            inside = np.abs(yrow - centre) <= c.corridor_half_width_m
            if not inside.any():  # the corridor left the view sideways: it goes on
                return c.free_road_max_m
            if mask[r, inside].mean() < c.corridor_min_road:
                return free
            free = x
        return c.free_road_max_m

    def _centre_points(self, x: np.ndarray, right: np.ndarray, left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ego-lane centre points, offset from each seen edge along the edge's normal.

        A row is a line of constant forward distance, which crosses a curving road
        obliquely; offsetting along the row would shrink every curve.
        """
        w = self.config.lane_width_m
        sr, sl = _edge_slopes(x, right), _edge_slopes(x, left)
        both = np.isfinite(right) & np.isfinite(left)
        if self.lanes is None and both.any():
            slope = np.where(np.isfinite(sr), sr, 0.0)[both]
            width = np.median((right[both] - left[both]) / np.sqrt(1.0 + slope**2))
            self.lanes = max(1, int(round(width / w)))
        if self.lane_from_right is None:  # median over rows: robust to a car hiding an edge
            ok_r, ok_l = np.isfinite(right), np.isfinite(left)
            if ok_r.any():
                dist = np.median(right[ok_r] / np.sqrt(1.0 + sr[ok_r] ** 2))
                self.lane_from_right = max(0, int(math.floor(dist / w)))
            elif ok_l.any() and self.lanes is not None:
                dist = np.median(-left[ok_l] / np.sqrt(1.0 + sl[ok_l] ** 2))
                self.lane_from_right = max(0, self.lanes - 1 - int(math.floor(dist / w)))
        k, n = self.lane_from_right, self.lanes
        pts = []
        steps = (0.0, *self.config.edge_steps_m)
        if k is not None:
            for xi, yi, si in zip(x, right, sr):
                if math.isfinite(yi):
                    norm = math.sqrt(1.0 + si * si)
                    # left normal (s, -1); one proposal per possible outward step of the edge
                    props = [(xi + d * si / norm, yi - d / norm) for d in (w / 2 + k * w + e for e in steps)]
                    pts.append(self._nearest(props))
        if k is not None and n is not None and k < n:
            for xi, yi, si in zip(x, left, sl):
                if math.isfinite(yi):
                    norm = math.sqrt(1.0 + si * si)
                    # right normal (-s, 1)
                    props = [(xi - d * si / norm, yi + d / norm) for d in (w / 2 + (n - 1 - k) * w + e for e in steps)]
                    pts.append(self._nearest(props))
        if not pts:  # no usable edge model: the road centre where both edges are seen
            pts = [
                (xi, 0.5 * (ri + li)) for xi, ri, li in zip(x, right, left) if math.isfinite(ri) and math.isfinite(li)
            ]
        if not pts:
            return np.zeros(0), np.zeros(0)
        arr = np.asarray(sorted(pts))
        if self._prev_coeffs is not None:  # temporal consistency: the lane moves little per frame
            near = np.abs(arr[:, 1] - np.polyval(self._prev_coeffs, arr[:, 0])) < self.config.path_jump_max_m
            arr = arr[near]
        if not len(arr):
            return np.zeros(0), np.zeros(0)
        return arr[:, 0], arr[:, 1]

    def _nearest(self, props: list[tuple[float, float]]) -> tuple[float, float]:
        """The proposed centre point nearest the previous path (the lane centre, 0, at first)."""
        if len(props) == 1:
            return props[0]
        prev = self._prev_coeffs
        return min(props, key=lambda p: abs(p[1] - (float(np.polyval(prev, p[0])) if prev is not None else 0.0)))

    def _fit(self, est: PathEstimate) -> np.ndarray:
        """Path Y(X) as quadratic coefficients (highest power first)."""
        c = self.config
        x, y = est.x_m, est.centre_y_m
        coeffs = None
        for _ in range(c.fit_rounds):  # fit, drop outliers (a car's side taken for a road edge), refit
            span = float(np.ptp(x)) if len(x) else 0.0
            if len(x) >= c.quadratic_min_points and span >= c.quadratic_min_span_m:
                coeffs = np.polyfit(x, y, 2)
            elif len(x) >= 2 and span >= c.line_min_span_m:
                coeffs = np.concatenate([[0.0], np.polyfit(x, y, 1)])
            elif len(x):
                coeffs = np.array([0.0, 0.0, float(np.median(y))])
            else:
                break
            resid = np.abs(y - np.polyval(coeffs, x))
            keep = resid <= max(c.outlier_min_m, c.outlier_mad_factor * float(np.median(resid)))
            if keep.all() or keep.sum() < 2:
                break
            x, y = x[keep], y[keep]
        if coeffs is None:
            return self._prev_coeffs if self._prev_coeffs is not None else np.zeros(3)
        return coeffs


def _rows_at(
    x_col: np.ndarray, distances: Iterable[float], tolerance: float, *, below_row: int
) -> tuple[list[int], list[float]]:
    """Image rows (above ``below_row``, each once) whose ground distance ``x_col``
    (m, per row, NaN off-ground) is within ``tolerance * d`` of each distance ``d``,
    and those rows' distances."""
    rows: list[int] = []
    xs: list[float] = []
    ok = np.nonzero(np.isfinite(x_col))[0]
    if len(ok) == 0:
        return rows, xs
    for d in distances:
        r = int(ok[np.argmin(np.abs(x_col[ok] - d))])
        if abs(x_col[r] - d) < tolerance * d and r not in rows and r < below_row:
            rows.append(r)
            xs.append(float(x_col[r]))
    return rows, xs


def _edge_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dY/dX of an edge seen at forward distances ``x`` (NaN where unseen), from a
    quadratic (>= 4 points) or line (2-3 points) fit; 0 with fewer points."""
    ok = np.isfinite(y)
    out = np.full(len(x), np.nan)
    if ok.sum() >= _EDGE_QUADRATIC_MIN_POINTS:
        c = np.polyfit(x[ok], y[ok], 2)
        out[ok] = 2 * c[0] * x[ok] + c[1]
    elif ok.sum() >= 2:
        out[ok] = np.polyfit(x[ok], y[ok], 1)[0]
    else:
        out[ok] = 0.0
    return out


def _occlusion_free(
    x: np.ndarray,
    edge: np.ndarray,
    inward: float,
    shape: np.ndarray | None,
    *,
    tol_m: float = _DEFAULTS.occlusion_tolerance_m,
    tol_per_m: float = _DEFAULTS.occlusion_tolerance_per_m,
) -> np.ndarray:
    """``edge`` (lateral position per look-ahead row, near to far) with the rows where
    something on the road hides the edge set to NaN.

    A road edge runs parallel to the road; a car on the road only ever cuts the run
    short, so the side of a car shows as a jump *inward* (``inward`` = -1 for the right
    edge, +1 for the left) from the edge continued from the nearer trusted rows. The
    edge is continued along ``shape`` (the previous frame's path, quadratic
    coefficients: it carries the road's curvature) or, without one, along a straight
    line through the last two trusted rows. Rows that jump inward by more than
    ``tol_m`` (plus ``tol_per_m`` times the distance from the last trusted row) are dropped;
    outward jumps -- the edge reappearing past a car -- are kept, and the edge is
    continued from there.
    """
    out = edge.copy()
    seen_x: list[float] = []
    seen_y: list[float] = []
    for k in range(len(x)):
        if not math.isfinite(out[k]):
            continue
        if seen_x:
            dx = float(x[k]) - seen_x[-1]
            if shape is not None:
                predicted = seen_y[-1] + float(np.polyval(shape, x[k]) - np.polyval(shape, seen_x[-1]))
            elif len(seen_x) >= 2:
                predicted = (
                    seen_y[-1] + (seen_y[-1] - seen_y[-2]) / max(seen_x[-1] - seen_x[-2], _MIN_ROW_SPACING_M) * dx
                )
            else:
                predicted = seen_y[-1]
            jump = inward * (out[k] - predicted)
            if jump > tol_m + tol_per_m * dx:
                out[k] = math.nan
                continue
            if -jump > tol_m + tol_per_m * dx:  # the edge past a car: continue from here
                seen_x, seen_y = [], []
        seen_x.append(float(x[k]))
        seen_y.append(float(out[k]))
    return out


def _pick_run(
    row: np.ndarray,
    y: np.ndarray,
    expect_y: float,
    *,
    max_gap_m: float = _DEFAULTS.bridge_gap_m,
    max_offset_m: float = _DEFAULTS.max_run_offset_m,
) -> tuple[int, int] | None:
    """The run of True pixels in ``row`` that contains lateral ``expect_y`` (else the
    nearest within ``max_offset_m``); returns (first, last) column indices or None.
    ``y`` is the lateral ground position (m) of each column."""
    padded = np.concatenate([[False], row, [False]]).astype(np.int8)
    d = np.diff(padded)
    starts = np.nonzero(d == 1)[0]
    ends = np.nonzero(d == -1)[0] - 1
    if len(starts) == 0:
        return None
    # Bridge gaps narrower than max_gap_m on the ground (a misread lane marking, a
    # sliver between two lanes): they do not split the road.
    if len(starts) > 1:
        gap = y[starts[1:]] - y[ends[:-1]]
        keep = np.concatenate([[True], gap > max_gap_m])
        starts = starts[keep]
        ends = np.concatenate([ends[:-1][keep[1:]], ends[-1:]])
    ya, yb = y[starts], y[ends]
    inside = (ya <= expect_y) & (expect_y <= yb)
    if inside.any():
        k = int(np.argmax(inside))
    else:
        gap = np.minimum(np.abs(ya - expect_y), np.abs(yb - expect_y))
        k = int(np.argmin(gap))
        if gap[k] > max_offset_m:
            return None
    return int(starts[k]), int(ends[k])
