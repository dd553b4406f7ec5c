"""Control: lane keeping from a road mask, drivers, and a ground-truth autopilot."""

from __future__ import annotations

from simroad.control.autopilot import autopilot_action, pure_pursuit_steering
from simroad.control.drivers import DRIVER_NAMES, SCENARIO_CONTROL, CallableDriver, MaskDriver, make_driver
from simroad.control.lane_keeping import ControllerConfig, MaskLaneKeeper, PathEstimate

__all__ = [
    "DRIVER_NAMES",
    "SCENARIO_CONTROL",
    "CallableDriver",
    "ControllerConfig",
    "MaskDriver",
    "MaskLaneKeeper",
    "PathEstimate",
    "autopilot_action",
    "make_driver",
    "pure_pursuit_steering",
]
