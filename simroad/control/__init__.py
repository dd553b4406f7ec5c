"""Control: lane keeping from a road mask, drivers, and a ground-truth autopilot."""

from __future__ import annotations

from simroad.control.autopilot import autopilot_action, pure_pursuit_steering
from simroad.control.config import ControllerConfig
from simroad.control.drivers import DRIVER_NAMES, CallableDriver, MaskDriver, make_driver
from simroad.control.lane_estimate import LaneEstimator, PathEstimate
from simroad.control.lane_keeping import MaskLaneKeeper

__all__ = [
    "DRIVER_NAMES",
    "CallableDriver",
    "ControllerConfig",
    "LaneEstimator",
    "MaskDriver",
    "MaskLaneKeeper",
    "PathEstimate",
    "autopilot_action",
    "make_driver",
    "pure_pursuit_steering",
]
