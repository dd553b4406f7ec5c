"""A ground-truth autopilot: pure pursuit on highway-env's own lane centre line.

It reads the true road geometry, never the camera, so it is a reference driver for
frame export and for checking the world; the perception-driven controller lives in
:mod:`simroad.control`.
"""

from __future__ import annotations

import math

import numpy as np

from simroad.core.validation import check_in_range
from simroad.envs.routes import follow_lanes
from simroad.errors import InvalidParameterError

__all__ = [
    "MAX_LOOKAHEAD_LANES",
    "STEERING_RANGE_RAD",
    "autopilot_action",
    "lane_lookahead_point",
    "pure_pursuit_steering",
]

#: highway-env's ``ContinuousAction`` maps steering action 1.0 to pi/4 rad.
STEERING_RANGE_RAD = math.pi / 4
#: Lane ends a look-ahead point may cross (far more than any look-ahead needs).
MAX_LOOKAHEAD_LANES = 8


def pure_pursuit_steering(pose: tuple[float, float, float], target: np.ndarray, wheelbase_m: float) -> float:
    """Steering angle (rad) that drives ``pose=(x, y, heading)`` through ``target`` (x, y).

    Classic pure pursuit: ``delta = atan(2 L sin(alpha) / l_d)``, with ``alpha`` the
    bearing of the target relative to the heading and ``l_d`` its distance.
    """
    try:
        x, y, h = pose
        dx, dy = target[0] - x, target[1] - y
        float(dx), float(dy), float(h)
    except (TypeError, ValueError, IndexError, KeyError):
        raise InvalidParameterError(
            f"pose, target: expected pose=(x, y, heading) and target=(x, y) numbers, got {pose!r} and {target!r}."
        ) from None
    check_in_range("wheelbase_m", wheelbase_m, 0.0, 100.0, unit="m", low_inclusive=False)
    ld = math.hypot(dx, dy)
    if ld < 1e-6:
        return 0.0
    alpha = math.atan2(dy, dx) - h
    alpha = math.atan2(math.sin(alpha), math.cos(alpha))
    return math.atan2(2.0 * wheelbase_m * math.sin(alpha), ld)


def lane_lookahead_point(road, vehicle, lookahead_m: float) -> np.ndarray:
    """World point ``lookahead_m`` ahead along the centre of the vehicle's lane.

    Follows the lane's successors (:func:`simroad.envs.routes.follow_lanes`) across
    at most :data:`MAX_LOOKAHEAD_LANES` lane ends; at a dead end the point is the last
    lane's end.
    """
    net = road.network
    index = net.get_closest_lane_index(vehicle.position, vehicle.heading)
    s, _ = net.get_lane(index).local_coordinates(vehicle.position)
    s_target = s + lookahead_m
    for k, (_index, lane) in enumerate(follow_lanes(net, index, position=vehicle.position)):
        if s_target <= lane.length or k == MAX_LOOKAHEAD_LANES:
            break
        s_target -= lane.length
    else:  # dead end
        s_target = lane.length
    return np.asarray(lane.position(s_target, 0.0))


def autopilot_action(road, vehicle, *, lookahead_s: float = 0.8, min_lookahead_m: float = 6.0) -> float:
    """Steering action in [-1, 1] for highway-env's ``ContinuousAction``.

    Pure pursuit from the rear axle onto the true lane centre, ``max(min_lookahead_m,
    lookahead_s * speed)`` metres ahead.

    Parameters
    ----------
    road : highway_env.road.road.Road
        The world (``env.highway_env.road`` of a :class:`~simroad.envs.RoadCamEnv`).
    vehicle : highway_env.vehicle.kinematics.Vehicle
        The car to steer (``env.vehicle``).
    lookahead_s : float
        Look-ahead time in s.
    min_lookahead_m : float
        Shortest look-ahead in m.
    """
    if not hasattr(road, "network"):
        raise InvalidParameterError(
            f"road: expected a highway-env Road (env.highway_env.road), got {type(road).__name__}."
        )
    if not all(hasattr(vehicle, a) for a in ("position", "heading", "speed", "LENGTH")):
        raise InvalidParameterError(
            f"vehicle: expected a highway-env Vehicle (env.vehicle), got {type(vehicle).__name__}."
        )
    check_in_range("lookahead_s", lookahead_s, 0.0, 10.0, unit="s")
    check_in_range("min_lookahead_m", min_lookahead_m, 0.0, 200.0, unit="m", low_inclusive=False)
    ld = max(min_lookahead_m, lookahead_s * float(vehicle.speed))
    target = lane_lookahead_point(road, vehicle, ld)
    # Rear axle: the point of highway-env's kinematic bicycle that moves along the heading.
    h = float(vehicle.heading)
    rear = np.asarray(vehicle.position, dtype=float) - 0.5 * float(vehicle.LENGTH) * np.array(
        [math.cos(h), math.sin(h)]
    )
    delta = pure_pursuit_steering((float(rear[0]), float(rear[1]), h), target, wheelbase_m=float(vehicle.LENGTH))
    return float(np.clip(delta / STEERING_RANGE_RAD, -1.0, 1.0))
