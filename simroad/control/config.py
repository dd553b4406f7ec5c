"""Tunables of the mask lane keeper: one validated, documented field per number."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from simroad.core.validation import check_fields_in_range, check_int_in_range
from simroad.envs.scenarios import ScenarioSpec
from simroad.envs.tyres import EGO_GRIP_USE
from simroad.errors import InvalidParameterError

__all__ = ["ControllerConfig"]


@dataclass(frozen=True)
class ControllerConfig:
    """Parameters of :class:`~simroad.control.MaskLaneKeeper` (lengths in m, speeds
    in m/s, accelerations in m/s^2). The defaults are the values every published
    result used; :meth:`for_scenario` sets the scenario's lane width and cruise speed.

    Parameters
    ----------
    lane_width_m : float, in [1, 10] m
        Nominal lane width used to offset the path from the right road edge.
    lookaheads_m : sequence of float
        Forward distances (from the car's centre, m, two or more, each in (0, 200])
        at which road edges are measured.
    lookahead_time_s : float, in (0, 10] s
    min_lookahead_m, max_lookahead_m : float, in (0, 200] m
        Pure-pursuit look-ahead ``clip(lookahead_time_s * speed, min, max)``.
    target_speed_m_s : float, in [0, 60] m/s
        Cruise speed.
    max_decel_m_s2 : float, in [0.1, 15] m/s^2
        Braking used to slow down for short free road ahead (and the lower bound of
        the acceleration command).
    max_accel_m_s2 : float, in [0.1, 15] m/s^2
        Upper bound of the acceleration command.
    speed_gain_1_s : float, in (0, 20] 1/s
        Proportional speed control: acceleration ``= speed_gain_1_s * (v_des - v)``.
    stop_margin_m : float, in [0, 100] m
        Free road kept in reserve when computing the safe speed.
    free_road_max_m : float, in (0, 500] m
        Farthest distance checked for free road ahead (beyond the path look-aheads).
    free_road_step_m : float, in (0, 100] m
        Spacing of the extra rows (beyond the path look-aheads) on which free road is
        measured.
    row_match_tolerance : float, in (0, 1]
        An image row stands for a look-ahead distance ``d`` when its ground distance
        on the centre column is within ``row_match_tolerance * d`` of it.
    corridor_half_width_m : float, in (0, 10] m
    corridor_min_road : float, in [0, 1]
        The car's corridor along the path: free road ends at the first look-ahead row
        where less than ``corridor_min_road`` of the corridor is road (a car ahead).
    max_lateral_accel_m_s2 : float, in [0.1, 15] m/s^2
        Curve speed limit ``sqrt(a / curvature)`` from the pure-pursuit arc.
    wheelbase_m : float, in [0.5, 20] m
        Effective wheelbase of highway-env's bicycle model (its vehicle length).
    bridge_gap_m : float, in [0, 10] m
        Gaps in a row's road run narrower than this on the ground (a misread lane
        marking, a sliver between two lanes) do not split the road.
    max_run_offset_m : float, in (0, 50] m
        With no road run containing the expected path position, the nearest run is
        taken if it is at most this far from it; else the road is lost on that row.
    occlusion_tolerance_m : float, in (0, 10] m
    occlusion_tolerance_per_m : float, in [0, 1]
        A road edge that jumps inward by more than ``occlusion_tolerance_m +
        occlusion_tolerance_per_m * dx`` from its continuation (``dx`` m ahead of the
        last trusted row) is a car's side, not the edge.
    path_jump_max_m : float, in (0, 20] m
        Temporal consistency: centre points farther than this from the previous
        frame's path are dropped.
    coast_frames : int, in [0, 100]
        Frames for which the previous path is held (and the car brakes) when no
        centre point of the mask lies within ``path_jump_max_m`` of it; after them
        the path is read from the mask alone.
    quadratic_min_points : int, in [3, 50]
    quadratic_min_span_m : float, in [0, 100] m
        The path is a quadratic when at least this many centre points span at least
        this forward distance; else a line (see ``line_min_span_m``) or a constant.
    line_min_span_m : float, in [0, 100] m
        The path is a line when two or more centre points span at least this far.
    outlier_min_m : float, in [0, 10] m
    outlier_mad_factor : float, in (0, 100]
        Centre points farther from the fit than ``max(outlier_min_m,
        outlier_mad_factor * median residual)`` are outliers (a car's side taken for
        a road edge); the path is refitted without them.
    fit_rounds : int, in [1, 20]
        Fit / drop-outliers rounds of the path fit.
    edge_steps_m : sequence of float, each in (0, 10] m
        Widths by which a road edge may step outwards beside the lanes (kerb-side
        parking strips in a town; empty elsewhere). Each seen edge then proposes the
        ego-lane centre at its lane offset and at that offset plus each step; the
        proposal nearest the previous path is taken, and centre points farther than
        ``path_jump_max_m`` from it are always dropped (a junction's mouth).
    grip_use : float, in (0, 1]
        Fraction of the tyres' grip ``μ·g`` the driver plans with when it knows μ
        (``info["mu"]``): its braking and acceleration, and the lateral acceleration
        of the curves it sees ahead, ``v <= sqrt(grip_use·μ·g / κ)``. The default,
        :data:`simroad.envs.tyres.EGO_GRIP_USE` (0.6), is also the share the ego's
        start speed is set with; it keeps the dry road's 4.7 m/s^2 above the default
        braking (``max_decel_m_s2``).
    """

    lane_width_m: float = 3.5
    lookaheads_m: tuple[float, ...] = (5.0, 6.0, 7.0, 9.0, 11.0, 13.0, 15.0, 18.0, 21.0, 25.0, 30.0, 36.0)
    lookahead_time_s: float = 0.9
    min_lookahead_m: float = 6.0
    max_lookahead_m: float = 25.0
    target_speed_m_s: float = 10.0
    max_decel_m_s2: float = 4.0
    max_accel_m_s2: float = 3.0
    speed_gain_1_s: float = 1.5
    stop_margin_m: float = 6.0
    free_road_max_m: float = 90.0
    free_road_step_m: float = 5.0
    row_match_tolerance: float = 0.25
    corridor_half_width_m: float = 1.1
    corridor_min_road: float = 0.8
    max_lateral_accel_m_s2: float = 2.0
    wheelbase_m: float = 5.0
    bridge_gap_m: float = 0.6
    max_run_offset_m: float = 3.0
    occlusion_tolerance_m: float = 0.6
    occlusion_tolerance_per_m: float = 0.05
    path_jump_max_m: float = 1.0
    coast_frames: int = 2
    quadratic_min_points: int = 4
    quadratic_min_span_m: float = 4.0
    line_min_span_m: float = 1.0
    outlier_min_m: float = 0.5
    outlier_mad_factor: float = 3.0
    fit_rounds: int = 3
    edge_steps_m: tuple[float, ...] = ()
    grip_use: float = EGO_GRIP_USE

    def __post_init__(self) -> None:
        ranges: dict[str, tuple[float, float, str, bool]] = {
            # name: (low, high, unit, low inclusive)
            "lane_width_m": (1.0, 10.0, "m", True),
            "lookahead_time_s": (0.0, 10.0, "s", False),
            "min_lookahead_m": (0.0, 200.0, "m", False),
            "max_lookahead_m": (0.0, 200.0, "m", False),
            "target_speed_m_s": (0.0, 60.0, "m/s", True),
            "max_decel_m_s2": (0.1, 15.0, "m/s^2", True),
            "max_accel_m_s2": (0.1, 15.0, "m/s^2", True),
            "speed_gain_1_s": (0.0, 20.0, "1/s", False),
            "stop_margin_m": (0.0, 100.0, "m", True),
            "free_road_max_m": (0.0, 500.0, "m", False),
            "free_road_step_m": (0.0, 100.0, "m", False),
            "row_match_tolerance": (0.0, 1.0, "", False),
            "corridor_half_width_m": (0.0, 10.0, "m", False),
            "corridor_min_road": (0.0, 1.0, "", True),
            "max_lateral_accel_m_s2": (0.1, 15.0, "m/s^2", True),
            "wheelbase_m": (0.5, 20.0, "m", True),
            "bridge_gap_m": (0.0, 10.0, "m", True),
            "max_run_offset_m": (0.0, 50.0, "m", False),
            "occlusion_tolerance_m": (0.0, 10.0, "m", False),
            "occlusion_tolerance_per_m": (0.0, 1.0, "m/m", True),
            "path_jump_max_m": (0.0, 20.0, "m", False),
            "quadratic_min_span_m": (0.0, 100.0, "m", True),
            "line_min_span_m": (0.0, 100.0, "m", True),
            "outlier_min_m": (0.0, 10.0, "m", True),
            "outlier_mad_factor": (0.0, 100.0, "", False),
            "grip_use": (0.0, 1.0, "", False),
        }
        check_fields_in_range(self, ranges)
        check_int_in_range("quadratic_min_points", self.quadratic_min_points, 3, 50)
        check_int_in_range("fit_rounds", self.fit_rounds, 1, 20)
        check_int_in_range("coast_frames", self.coast_frames, 0, 100)
        if self.min_lookahead_m > self.max_lookahead_m:
            raise InvalidParameterError(
                f"min_lookahead_m: expected at most max_lookahead_m={self.max_lookahead_m:g} m, "
                f"got {self.min_lookahead_m:g} m."
            )
        ahead = self.lookaheads_m
        try:
            values = tuple(float(d) for d in ahead)
        except (TypeError, ValueError):
            values = ()
        if isinstance(ahead, str) or len(values) < 2 or not all(0.0 < d <= 200.0 for d in values):
            raise InvalidParameterError(
                f"lookaheads_m: expected two or more distances in (0, 200] m, got {ahead!r}. "
                "Pass e.g. (5.0, 10.0, 20.0)."
            )
        object.__setattr__(self, "lookaheads_m", values)
        steps = self.edge_steps_m
        try:
            widths = tuple(float(d) for d in steps)
        except (TypeError, ValueError):
            widths = (math.nan,)
        if isinstance(steps, str) or not all(0.0 < d <= 10.0 for d in widths):
            raise InvalidParameterError(
                f"edge_steps_m: expected a sequence of widths in (0, 10] m (empty for none), got {steps!r}. "
                "Pass e.g. (2.3,) for kerb-side parking strips."
            )
        object.__setattr__(self, "edge_steps_m", widths)

    @classmethod
    def for_scenario(cls, scenario: ScenarioSpec, **overrides: Any) -> ControllerConfig:
        """The defaults with the scenario's lane width, cruise speed and parking strip
        width (``edge_steps_m``), then ``overrides``."""
        if not isinstance(scenario, ScenarioSpec):
            raise InvalidParameterError(
                f"scenario: expected a ScenarioSpec (simroad.envs.get_scenario(name)), got {scenario!r}."
            )
        steps = (scenario.parking_width_m,) if scenario.parking_width_m > 0 else ()
        base = cls(lane_width_m=scenario.lane_width_m, target_speed_m_s=scenario.cruise_speed_m_s, edge_steps_m=steps)
        return dataclasses.replace(base, **overrides) if overrides else base
