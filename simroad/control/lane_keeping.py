"""Lane keeping driven by a road mask alone.

The camera is fixed to the car and the ground is flat, so every image row below the
horizon is a line of constant forward distance on the ground: inverse perspective
mapping of the mask is a per-row lookup of the camera's constant ego-frame ground map.

Per look-ahead row the controller finds the road run the car is on, its right (and
left) edge in metres, and the centre of the ego's lane (offset from the right edge by
lane widths; the road centre when no edge is seen). A quadratic fitted through those
centres is the path; pure pursuit steers onto it, and the speed is held at a target
and lowered when the detected free road ahead is short.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simroad._validation import SimroadError, check_in_range, check_mask
from simroad.camera.geometry import PinholeCamera
from simroad.control.autopilot import STEERING_RANGE_RAD, pure_pursuit_steering

__all__ = ["ControllerConfig", "MaskLaneKeeper", "PathEstimate"]

#: highway-env's ContinuousAction maps acceleration action 1.0 to 5 m/s^2.
ACCEL_RANGE_M_S2 = 5.0


@dataclass(frozen=True)
class ControllerConfig:
    """Parameters of :class:`MaskLaneKeeper` (lengths in m, speeds in m/s).

    Parameters
    ----------
    lane_width_m : float
        Nominal lane width used to offset the path from the right road edge.
    lookaheads_m : tuple of float
        Forward distances (from the car's centre) at which road edges are measured.
    lookahead_time_s, min_lookahead_m, max_lookahead_m : float
        Pure-pursuit look-ahead ``clip(lookahead_time_s * speed, min, max)``.
    target_speed_m_s : float
        Cruise speed.
    max_decel_m_s2 : float
        Braking used to slow down for short free road ahead.
    stop_margin_m : float
        Free road kept in reserve when computing the safe speed.
    free_road_max_m : float
        Farthest distance checked for free road ahead (beyond the path look-aheads).
    corridor_half_width_m, corridor_min_road : float
        The car's corridor along the path: free road ends at the first look-ahead row
        where less than ``corridor_min_road`` of the corridor is road (a car ahead).
    max_lateral_accel_m_s2 : float
        Curve speed limit ``sqrt(a / curvature)`` from the fitted path.
    wheelbase_m : float
        Effective wheelbase of highway-env's bicycle model (its vehicle length).
    """

    lane_width_m: float = 3.5
    lookaheads_m: tuple[float, ...] = (5.0, 6.0, 7.0, 9.0, 11.0, 13.0, 15.0, 18.0, 21.0, 25.0, 30.0, 36.0)
    lookahead_time_s: float = 0.9
    min_lookahead_m: float = 6.0
    max_lookahead_m: float = 25.0
    target_speed_m_s: float = 10.0
    max_decel_m_s2: float = 4.0
    stop_margin_m: float = 6.0
    free_road_max_m: float = 90.0
    corridor_half_width_m: float = 1.1
    corridor_min_road: float = 0.8
    max_lateral_accel_m_s2: float = 2.0
    wheelbase_m: float = 5.0

    def __post_init__(self) -> None:
        check_in_range("lane_width_m", self.lane_width_m, 1.0, 10.0, unit="m")
        check_in_range("target_speed_m_s", self.target_speed_m_s, 0.0, 60.0, unit="m/s")
        check_in_range("max_decel_m_s2", self.max_decel_m_s2, 0.1, 15.0, unit="m/s^2")
        if len(self.lookaheads_m) < 2 or any(d <= 0 for d in self.lookaheads_m):
            raise SimroadError(f"lookaheads_m: expected two or more positive distances, got {self.lookaheads_m!r}.")


@dataclass
class PathEstimate:
    """What the controller read off one mask (ego frame: X forward, Y right, metres)."""

    x_m: np.ndarray  # look-ahead distances with a measurement
    centre_y_m: np.ndarray  # ego-lane centre at those distances
    right_y_m: np.ndarray  # right road edge (NaN where not seen)
    left_y_m: np.ndarray  # left road edge (NaN where not seen)
    free_road_m: float  # farthest look-ahead up to which the road, and the car's corridor on it, is free
    coeffs: np.ndarray = field(default_factory=lambda: np.zeros(3))  # path Y(X), highest power first


class MaskLaneKeeper:
    """Steer and hold speed from a bool road mask.

    Parameters
    ----------
    camera : PinholeCamera
        The calibrated camera that produced the masks (its mounting only).
    config : ControllerConfig
    """

    def __init__(self, camera: PinholeCamera, config: ControllerConfig | None = None) -> None:
        self.camera = camera
        self.config = config or ControllerConfig()
        ground = camera.ego_ground
        H = camera.config.height
        centre_col = camera.config.width // 2
        x_col = ground[:, centre_col, 0]
        self._rows, self._x = [], []
        for d in self.config.lookaheads_m:
            ok = np.nonzero(np.isfinite(x_col))[0]
            if len(ok) == 0:
                break
            r = int(ok[np.argmin(np.abs(x_col[ok] - d))])
            if abs(x_col[r] - d) < 0.25 * d and r not in self._rows and r < H:
                self._rows.append(r)
                self._x.append(float(x_col[r]))
        if len(self._rows) < 2:
            raise SimroadError(
                "camera: too few image rows see the look-ahead distances; lower the pitch or the look-aheads."
            )
        self._rows = np.asarray(self._rows)
        self._x = np.asarray(self._x)
        self._row_y = ground[self._rows, :, 1]  # (n_rows, W) lateral position of each column
        # Rows beyond the path look-aheads, every ~5 m, only to measure free road.
        self._free_rows, self._free_x = [], []
        for d in np.arange(self._x[-1] + 5.0, self.config.free_road_max_m + 1e-6, 5.0):
            ok = np.nonzero(np.isfinite(x_col))[0]
            r = int(ok[np.argmin(np.abs(x_col[ok] - d))])
            if abs(x_col[r] - d) < 0.25 * d and r not in self._free_rows and r < int(self._rows[-1]):
                self._free_rows.append(r)
                self._free_x.append(float(x_col[r]))
        # Every row the car's corridor is checked on, near to far.
        self._check_rows = list(self._rows) + self._free_rows
        self._check_x = list(self._x) + self._free_x
        self._check_y = ground[self._check_rows, :, 1]
        self.reset()

    def reset(self) -> None:
        """Forget the lane index and the previous path (call at episode start)."""
        self.lane_from_right: int | None = None
        self.lanes: int | None = None
        self._prev_coeffs: np.ndarray | None = None
        self.last: PathEstimate | None = None

    # --------------------------------------------------------------- perception
    def read_path(self, mask: np.ndarray) -> PathEstimate:
        """Measure road edges on the look-ahead rows and the ego-lane centre line."""
        mask = check_mask("mask", mask, shape=(self.camera.config.height, self.camera.config.width))
        W = mask.shape[1]
        xs, rights, lefts = [], [], []
        free = 0.0
        for k, r in enumerate(self._rows):
            yrow = self._row_y[k]
            expect = 0.0 if self._prev_coeffs is None else float(np.polyval(self._prev_coeffs, self._x[k]))
            run = _pick_run(mask[r], yrow, expect)
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
        right = _occlusion_free(x, np.asarray(rights), -1.0, shape)
        left = _occlusion_free(x, np.asarray(lefts), 1.0, shape)
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
        if k is not None:
            d = w / 2 + k * w
            for xi, yi, si in zip(x, right, sr):
                if math.isfinite(yi):
                    norm = math.sqrt(1.0 + si * si)
                    pts.append((xi + d * si / norm, yi - d / norm))  # left normal (s, -1)
        if k is not None and n is not None and k < n:
            d = w / 2 + (n - 1 - k) * w
            for xi, yi, si in zip(x, left, sl):
                if math.isfinite(yi):
                    norm = math.sqrt(1.0 + si * si)
                    pts.append((xi - d * si / norm, yi + d / norm))  # right normal (-s, 1)
        if not pts:  # no usable edge model: the road centre where both edges are seen
            pts = [
                (xi, 0.5 * (ri + li)) for xi, ri, li in zip(x, right, left) if math.isfinite(ri) and math.isfinite(li)
            ]
        if not pts:
            return np.zeros(0), np.zeros(0)
        arr = np.asarray(sorted(pts))
        if self._prev_coeffs is not None:  # temporal consistency: the lane moves little per frame
            near = np.abs(arr[:, 1] - np.polyval(self._prev_coeffs, arr[:, 0])) < 1.0
            if near.sum() >= 2:
                arr = arr[near]
        return arr[:, 0], arr[:, 1]

    def _fit(self, est: PathEstimate) -> np.ndarray:
        """Path Y(X) as quadratic coefficients (highest power first)."""
        x, y = est.x_m, est.centre_y_m
        coeffs = None
        for _ in range(3):  # fit, drop outliers (a car's side taken for a road edge), refit
            span = float(np.ptp(x)) if len(x) else 0.0
            if len(x) >= 4 and span >= 4.0:
                coeffs = np.polyfit(x, y, 2)
            elif len(x) >= 2 and span >= 1.0:
                coeffs = np.concatenate([[0.0], np.polyfit(x, y, 1)])
            elif len(x):
                coeffs = np.array([0.0, 0.0, float(np.median(y))])
            else:
                break
            resid = np.abs(y - np.polyval(coeffs, x))
            keep = resid <= max(0.5, 3.0 * float(np.median(resid)))
            if keep.all() or keep.sum() < 2:
                break
            x, y = x[keep], y[keep]
        if coeffs is None:
            return self._prev_coeffs if self._prev_coeffs is not None else np.zeros(3)
        return coeffs

    # ------------------------------------------------------------------ control
    def act(self, mask: np.ndarray, speed_m_s: float) -> np.ndarray:
        """Return ``[steering, acceleration]`` actions in [-1, 1] for highway-env."""
        est = self.read_path(mask)
        self.last = est
        self._prev_coeffs = est.coeffs
        c = self.config
        ld = float(np.clip(c.lookahead_time_s * speed_m_s, c.min_lookahead_m, c.max_lookahead_m))
        if len(est.x_m):  # stay on the measured part of the path: never extrapolate
            ld = float(np.clip(ld, est.x_m.min(), est.x_m.max()))
        target = np.array([ld, float(np.polyval(est.coeffs, ld))])
        # Pure pursuit from the rear axle: in highway-env's kinematic bicycle (centre of
        # gravity midway, sideslip beta) only the rear axle moves along the heading.
        delta = pure_pursuit_steering((-c.wheelbase_m / 2.0, 0.0, 0.0), target, c.wheelbase_m)
        steer = float(np.clip(delta / STEERING_RANGE_RAD, -1.0, 1.0))
        safe = math.sqrt(2.0 * c.max_decel_m_s2 * max(0.0, est.free_road_m - c.stop_margin_m))
        # Curvature of the arc pure pursuit will drive (bounded by geometry, unlike the
        # second derivative of a fitted polynomial).
        rear = np.array([-c.wheelbase_m / 2.0, 0.0])
        d = target - rear
        kappa = abs(2.0 * d[1]) / float(d @ d)
        curve = math.sqrt(c.max_lateral_accel_m_s2 / kappa) if kappa > 1e-6 else math.inf
        v_des = min(c.target_speed_m_s, safe, curve)
        accel = float(np.clip(1.5 * (v_des - speed_m_s), -c.max_decel_m_s2, 3.0)) / ACCEL_RANGE_M_S2
        return np.array([steer, accel], dtype=np.float32)


def _edge_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dY/dX of an edge seen at forward distances ``x`` (NaN where unseen), from a
    quadratic (>= 4 points) or line (2-3 points) fit; 0 with fewer points."""
    ok = np.isfinite(y)
    out = np.full(len(x), np.nan)
    if ok.sum() >= 4:
        c = np.polyfit(x[ok], y[ok], 2)
        out[ok] = 2 * c[0] * x[ok] + c[1]
    elif ok.sum() >= 2:
        out[ok] = np.polyfit(x[ok], y[ok], 1)[0]
    else:
        out[ok] = 0.0
    return out


def _occlusion_free(
    x: np.ndarray, edge: np.ndarray, inward: float, shape: np.ndarray | None, tol_m: float = 0.6
) -> np.ndarray:
    """``edge`` (lateral position per look-ahead row, near to far) with the rows where
    something on the road hides the edge set to NaN.

    A road edge runs parallel to the road; a car on the road only ever cuts the run
    short, so the side of a car shows as a jump *inward* (``inward`` = -1 for the right
    edge, +1 for the left) from the edge continued from the nearer trusted rows. The
    edge is continued along ``shape`` (the previous frame's path, quadratic
    coefficients: it carries the road's curvature) or, without one, along a straight
    line through the last two trusted rows. Rows that jump inward by more than
    ``tol_m`` (plus 5 % of the distance from the last trusted row) are dropped;
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
                predicted = seen_y[-1] + (seen_y[-1] - seen_y[-2]) / max(seen_x[-1] - seen_x[-2], 1e-6) * dx
            else:
                predicted = seen_y[-1]
            jump = inward * (out[k] - predicted)
            if jump > tol_m + 0.05 * dx:
                out[k] = math.nan
                continue
            if -jump > tol_m + 0.05 * dx:  # the edge past a car: continue from here
                seen_x, seen_y = [], []
        seen_x.append(float(x[k]))
        seen_y.append(float(out[k]))
    return out


def _pick_run(row: np.ndarray, y: np.ndarray, expect_y: float, max_gap_m: float = 0.6) -> tuple[int, int] | None:
    """The run of True pixels in ``row`` that contains lateral ``expect_y`` (else the
    nearest within 3 m); returns (first, last) column indices or None."""
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
        if gap[k] > 3.0:
            return None
    return int(starts[k]), int(ends[k])
