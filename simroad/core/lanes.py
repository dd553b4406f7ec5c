"""Vectorised lane coordinates and signed distance fields of highway-env lanes.

``lane_local(lane, x, y)`` evaluates highway-env's ``lane.local_coordinates`` on
whole arrays of points (the formulas of ``StraightLane``, ``SineLane`` and
``CircularLane``, including CircularLane's phase wrapping). The signed distance of
a point to a lane's surface is positive inside the lane rectangle in (s, lateral)
coordinates; with bilinear interpolation its zero crossing gives the lane edge to
sub-texel precision.
"""

from __future__ import annotations

import numpy as np
from highway_env.road.lane import CircularLane, SineLane, StraightLane

__all__ = ["lane_local", "lane_positions", "lane_signed_distance", "supports_vectorised"]


def supports_vectorised(lane) -> bool:
    """Whether :func:`lane_local` has an exact vectorised form for ``lane``."""
    return type(lane) in (StraightLane, SineLane, CircularLane)


def lane_local(lane, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal and lateral lane coordinates (m) of world points ``(x, y)``."""
    if type(lane) in (StraightLane, SineLane):
        dx, dy = x - lane.start[0], y - lane.start[1]
        s = dx * lane.direction[0] + dy * lane.direction[1]
        lat = dx * lane.direction_lateral[0] + dy * lane.direction_lateral[1]
        if type(lane) is SineLane:
            lat = lat - lane.amplitude * np.sin(lane.pulsation * s + lane.phase)
        return s, lat
    if type(lane) is CircularLane:
        dx, dy = x - lane.center[0], y - lane.center[1]
        phi = np.arctan2(dy, dx)
        d = phi - lane.start_phase
        phi = lane.start_phase + (d + np.pi) % (2 * np.pi) - np.pi  # highway-env's wrap_to_pi
        r = np.hypot(dx, dy)
        return lane.direction * (phi - lane.start_phase) * lane.radius, lane.direction * (lane.radius - r)
    raise TypeError(f"no vectorised local coordinates for {type(lane).__name__}")


def lane_positions(lane, s: np.ndarray, lat: np.ndarray) -> np.ndarray:
    """World positions (N, 2) of lane coordinates ``(s_i, lat_i)``: highway-env's
    ``StraightLane.position`` and ``CircularLane.position`` on whole arrays, the same
    operations in the same order (so the same numbers)."""
    if type(lane) is StraightLane:
        return lane.start + s[:, None] * lane.direction + lat[:, None] * lane.direction_lateral
    if type(lane) is CircularLane:
        phi = lane.direction * s / lane.radius + lane.start_phase
        ring = (lane.radius - lat * lane.direction)[:, None]
        return lane.center + ring * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    raise TypeError(f"no vectorised positions for {type(lane).__name__}")


def lane_signed_distance(lane, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed distance (m, float32) to the lane surface: > 0 inside, < 0 outside.

    Inside the lane's longitudinal span it is the lateral margin ``w/2 - |lat|``;
    past either end the longitudinal overrun is subtracted too.
    """
    s, lat = lane_local(lane, x, y)
    half = lane.width_at(0.0) / 2.0
    lateral = half - np.abs(lat)
    overrun = np.maximum(np.maximum(-s, s - lane.length), 0.0)
    return np.where(overrun > 0, np.minimum(lateral, 0.0) - overrun, lateral).astype(np.float32)
