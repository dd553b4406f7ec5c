"""highway-env's vehicles on a road with friction: the friction circle in every step.

:func:`attach_grip` turns the vehicles of a highway-env road into subclasses of their
own classes (:func:`grip_class`, in place: same object, same state) whose ``step`` passes the demanded acceleration
through the friction circle (:func:`simroad.envs.friction.friction_limit`) before
highway-env's kinematic bicycle integrates it; everything else of highway-env's
kinematics is kept. Demanded lateral acceleration is ``v²·κ``, with ``κ = 2·sin(β)/L``
the path curvature of highway-env's bicycle (``β = atan(tan(δ)/2)``, L its length);
when the tyres slide the steering is replaced by the one that gives the curvature
they deliver (understeer), and braking by what they deliver (a longer stop). Braking
brings the car to a halt, never into reverse.

IDM traffic (:class:`~highway_env.vehicle.behavior.IDMVehicle`) also plans with its
grip: it uses at most :attr:`GripIDMVehicle.BRAKE_USE` of ``μ·g`` for its comfortable
braking and acceleration (so it keeps longer gaps on a slippery road) and holds its
target speed below what the curves ahead allow at :attr:`GripIDMVehicle.CORNER_USE`
of ``μ·g``, braking for them in time.

Every car also *starts* at a speed its planner would hold there (:func:`attach_grip`):
no faster than it can brake from, at the share of ``μ·g`` it plans with, to take every
curve within its stopping distance at that share (:meth:`LanesAhead.curve_speed_m_s`:
``min_k sqrt(a·/κ_k + 2·a·d_k)``), and never faster than highway-env started it (the
scenario's cruise speed). The ego's share is :data:`EGO_GRIP_USE`, the one its planners
(the lane keeper and the oracle) use by default; the traffic's is
:attr:`GripIDMVehicle.CORNER_USE`. On ice a car starts slow instead of arriving at the
first curve at the dry road's cruise speed.
"""

from __future__ import annotations

import math
from typing import Any

from highway_env.road.lane import CircularLane, StraightLane
from highway_env.vehicle.behavior import IDMVehicle
from highway_env.vehicle.kinematics import Vehicle

from simroad.core.constants import GRAVITY_M_S2
from simroad.envs._town_parts import ParkedVehicle
from simroad.envs.friction import RoadGrip, friction_limit
from simroad.envs.routes import follow_lanes
from simroad.errors import InvalidParameterError

__all__ = [
    "EGO_GRIP_USE",
    "GripIDMVehicle",
    "GripVehicle",
    "LanesAhead",
    "attach_grip",
    "grip_class",
    "start_speed_m_s",
]

#: Lanes ahead a driver of the traffic looks at for curves (more than any braking needs).
_LANES_AHEAD = 4
#: Lanes a start speed looks along at most (the stopping distance ends far sooner).
_START_LANES = 64
#: Fraction of ``μ·g`` the ego's planners brake and take curves with (the default of
#: :attr:`simroad.control.config.ControllerConfig.grip_use`), and so the one its start
#: speed is set with: 0.6 keeps the dry road's 4.7 m/s^2 above the lane keeper's braking.
EGO_GRIP_USE = 0.6


class GripVehicle(Vehicle):
    """highway-env's ``Vehicle`` (the ego of ``ContinuousAction``) with the friction
    circle in its ``step`` (see the module docstring); the base of every vehicle
    class :func:`grip_class` makes.

    Attributes
    ----------
    grip : RoadGrip or None
        The road's friction; None is highway-env's own, unlimited, dynamics.
    mu : float
        μ under the vehicle at its last step.
    sliding : bool
        Whether the tyres slid in the last step.
    slides : int
        Steps (physics steps, ``simulation_hz``) in which the tyres slid.
    """

    grip: RoadGrip | None = None
    mu: float = math.inf
    sliding: bool = False
    slides: int = 0

    def step(self, dt: float) -> None:
        grip = self.grip
        if grip is None or self.crashed:  # a crashed car: highway-env's own halt
            super().step(dt)
            return
        self.clip_actions()
        wanted = self.action  # type: ignore[has-type]  # highway-env leaves its attributes untyped
        steer, accel = float(wanted["steering"]), float(wanted["acceleration"])
        x, y = self.position
        mu = grip.mu_at(float(x), float(y))
        v = float(self.speed)  # type: ignore[has-type]
        length = float(self.LENGTH)
        kappa = 2.0 * math.sin(math.atan(0.5 * math.tan(steer))) / length
        a_long, a_lat, sliding = friction_limit(accel, v * v * kappa, mu)
        self.mu, self.sliding = mu, sliding
        self.slides += int(sliding)
        delivered = {"steering": steer, "acceleration": a_long}
        if sliding and v * v > 1e-9:
            beta = math.asin(max(-1.0, min(1.0, a_lat / (v * v) * length / 2.0)))
            delivered["steering"] = math.atan(2.0 * math.tan(beta))
        self.action = delivered
        try:
            super().step(dt)
        finally:
            self.action = wanted
        if a_long < 0.0 <= v and float(getattr(self, "speed")) < 0.0:  # noqa: B009
            self.speed = 0.0  # braking stops the car; it does not reverse


class GripIDMVehicle(GripVehicle, IDMVehicle):
    """highway-env's ``IDMVehicle`` with the friction circle, braking and cornering
    within its grip (see the module docstring)."""

    #: Fraction of ``μ·g`` IDM traffic brakes and accelerates with at most (its
    #: comfortable 5 and 3 m/s^2 are kept on a dry road: 0.65·0.8·g = 5.1).
    BRAKE_USE = 0.65
    #: Fraction of ``μ·g`` IDM traffic takes curves with (0.6 already slides at the
    #: entry of an arc after a straight, where highway-env's steering overshoots).
    CORNER_USE = 0.5
    lanes_ahead: LanesAhead | None = None

    def act(self, action: Any = None) -> None:
        grip = self.grip
        if grip is None or self.crashed:
            super().act(action)
            return
        mu = self.mu if math.isfinite(self.mu) else grip.mu_at(*map(float, self.position))
        brake, corner = self.BRAKE_USE * mu * GRAVITY_M_S2, self.CORNER_USE * mu * GRAVITY_M_S2
        # IDM's comfortable deceleration b and acceleration a, per car (its desired gap grows as sqrt(a·b) falls)
        setattr(self, "COMFORT_ACC_MIN", -min(-_IDM_ACC_MIN, brake))  # noqa: B010
        setattr(self, "COMFORT_ACC_MAX", min(_IDM_ACC_MAX, brake))  # noqa: B010
        target = float(getattr(self, "target_speed"))  # noqa: B009
        if self.lanes_ahead is not None:
            limit = self.lanes_ahead.curve_speed_m_s(self, corner, corner)  # and brakes for it gently
            self.target_speed = min(target, limit)
        try:
            super().act(action)
        finally:
            self.target_speed = target


#: highway-env vehicle class -> its friction-circle subclass (made once).
_MADE: dict[type, type] = {Vehicle: GripVehicle, IDMVehicle: GripIDMVehicle}
_IDM_ACC_MIN, _IDM_ACC_MAX = float(IDMVehicle.COMFORT_ACC_MIN), float(IDMVehicle.COMFORT_ACC_MAX)


def grip_class(cls: type) -> type:
    """The friction-circle subclass of highway-env vehicle class ``cls`` (cached)."""
    if not (isinstance(cls, type) and issubclass(cls, Vehicle)):
        raise InvalidParameterError(f"cls: expected a highway-env Vehicle class, got {cls!r}.")
    if issubclass(cls, GripVehicle):
        return cls
    if cls not in _MADE:
        base = GripIDMVehicle if issubclass(cls, IDMVehicle) else GripVehicle
        _MADE[cls] = type(f"Grip{cls.__name__}", (base, cls), {"__module__": __name__, "__doc__": cls.__doc__})
    return _MADE[cls]


class LanesAhead:
    """Curvature of the lanes ahead, cached per lane (lanes never change shape)."""

    def __init__(self, network: Any) -> None:
        self.network = network
        self._kappa: dict[Any, float] = {}
        self._next: dict[Any, Any] = {}

    def curvature(self, index: Any) -> float:
        """Largest |curvature| (1/m) of lane ``index``."""
        if index not in self._kappa:
            lane = self.network.get_lane(index)
            if isinstance(lane, StraightLane):
                k = 0.0
            elif isinstance(lane, CircularLane):
                k = 1.0 / float(lane.radius)
            else:  # sample the heading along the lane
                n = max(2, int(lane.length // 2.0))
                ds = float(lane.length) / n
                hs = [float(lane.heading_at(i * ds)) for i in range(n + 1)]
                k = max(abs(math.remainder(b - a, math.tau)) / ds for a, b in zip(hs, hs[1:], strict=False))
            self._kappa[index] = k
        return self._kappa[index]

    def successor(self, index: Any, position: Any) -> Any:
        """The lane after ``index`` (highway-env's successor rule, :func:`follow_lanes`), or None."""
        if index not in self._next:
            walk = follow_lanes(self.network, index, position=position)
            next(walk)
            self._next[index] = next(walk, (None, None))[0]
        return self._next[index]

    def curve_speed_m_s(
        self, vehicle: Any, lateral_m_s2: float, brake_m_s2: float, *, max_lanes: int = _LANES_AHEAD
    ) -> float:
        """Highest speed from which ``vehicle`` can brake (at ``brake_m_s2``) to take
        every curve of its lane and the next ones at ``lateral_m_s2``: the minimum over
        lanes k of ``sqrt(a_lat/κ_k + 2·a_brake·d_k)``, d_k the distance to lane k, over
        the lanes that begin within its stopping distance (``max_lanes`` at most)."""
        index = vehicle.lane_index
        lane = self.network.get_lane(index)
        s, _ = lane.local_coordinates(vehicle.position)
        limit, dist = math.inf, -float(s)
        horizon = float(vehicle.speed) ** 2 / (2.0 * brake_m_s2)
        for _ in range(max_lanes):
            k = self.curvature(index)
            if k > 0.0:
                limit = min(limit, math.sqrt(lateral_m_s2 / k + 2.0 * brake_m_s2 * max(0.0, dist)))
            dist += float(self.network.get_lane(index).length)
            index = self.successor(index, vehicle.position)
            if index is None or dist > horizon:
                break
        return limit


def attach_grip(road: Any, grip: RoadGrip) -> None:
    """Put every moving vehicle of highway-env ``road`` on ``grip``: each becomes its
    :func:`grip_class` (same state, same object) with the road's friction. Parked
    cars never move and are left as they are."""
    if not isinstance(grip, RoadGrip):
        raise InvalidParameterError(
            f"grip: expected a RoadGrip (simroad.envs.friction.road_grip), got {type(grip).__name__}."
        )
    ahead = LanesAhead(road.network)
    for v in road.vehicles:
        if isinstance(v, ParkedVehicle) or not isinstance(v, Vehicle):
            continue
        v.__class__ = grip_class(type(v))
        v.grip = grip
        v.mu = grip.mu_at(float(v.position[0]), float(v.position[1]))
        v.sliding, v.slides = False, 0
        share = EGO_GRIP_USE
        if isinstance(v, GripIDMVehicle):
            v.lanes_ahead = ahead
            share = v.CORNER_USE
        v.speed = start_speed_m_s(v, ahead, share * v.mu * GRAVITY_M_S2)


def start_speed_m_s(vehicle: Any, lanes: LanesAhead, accel_m_s2: float) -> float:
    """The speed ``vehicle`` may start at: its speed, at most the speed from which,
    braking at ``accel_m_s2``, it takes every curve within its stopping distance at a
    lateral ``accel_m_s2`` (:meth:`LanesAhead.curve_speed_m_s` at its current speed,
    whose stopping distance covers every curve that can bind a slower start)."""
    speed = float(vehicle.speed)
    if speed <= 0.0:
        return speed
    return min(speed, lanes.curve_speed_m_s(vehicle, accel_m_s2, accel_m_s2, max_lanes=_START_LANES))
