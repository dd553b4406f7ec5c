"""Drivers: what turns an observation into an action.

``detector``
    A :class:`~simroad.detector.RoadDetector` (any filter set) predicts the road
    mask from the camera frame; :class:`MaskLaneKeeper` steers from that mask.
``oracle``
    The same controller on the ground-truth mask: the difference between the two is
    what perception errors cost.

Any callable ``obs -> action`` (an RL policy, a user's own detector + controller)
plugs in the same way through :class:`CallableDriver`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from simroad._validation import SimroadError, check_choice
from simroad.control.lane_keeping import ControllerConfig, MaskLaneKeeper

__all__ = ["DRIVER_NAMES", "SCENARIO_CONTROL", "CallableDriver", "MaskDriver", "make_driver"]

DRIVER_NAMES = ("detector", "oracle")

#: Map priors per scenario: nominal lane width (m) and cruise speed (m/s).
SCENARIO_CONTROL = {
    "racetrack": {"lane_width_m": 5.0, "target_speed_m_s": 10.0},
    "highway": {"lane_width_m": 4.0, "target_speed_m_s": 25.0},
    "winding": {"lane_width_m": 3.5, "target_speed_m_s": 15.0},
}


class MaskDriver:
    """Lane keeping from a road mask: predicted (detector) or ground truth (oracle).

    Parameters
    ----------
    env : RoadCamEnv
        The (unwrapped) environment; only its camera calibration is used.
    detector : RoadDetector or None
        None means the oracle: the mask is ``info["road_mask"]``.
    control : ControllerConfig, optional
    """

    def __init__(self, env, detector=None, control: ControllerConfig | None = None) -> None:
        if not env.config.longitudinal:
            raise SimroadError("env: mask drivers control speed too; create the environment with longitudinal=True.")
        self.detector = detector
        self.controller = MaskLaneKeeper(
            env.camera, control or ControllerConfig(**SCENARIO_CONTROL[env.config.scenario])
        )
        self.last_mask: np.ndarray | None = None

    def reset(self) -> None:
        self.controller.reset()

    def __call__(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        mask = info["road_mask"] if self.detector is None else self.detector.predict(obs)
        self.last_mask = mask
        return self.controller.act(mask, float(info["speed_m_s"]))


class CallableDriver:
    """Wrap a user callable ``obs -> action``; its predicted mask, if it returns
    ``(action, mask)``, is scored like the detector's."""

    def __init__(self, fn: Callable[[np.ndarray], Any]) -> None:
        if not callable(fn):
            raise SimroadError(f"driver: expected 'detector', 'oracle' or a callable obs -> action, got {fn!r}.")
        self.fn = fn
        self.last_mask: np.ndarray | None = None

    def reset(self) -> None:
        reset = getattr(self.fn, "reset", None)
        if callable(reset):
            reset()

    def __call__(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        out = self.fn(obs)
        if isinstance(out, tuple) and len(out) == 2:
            out, self.last_mask = out
        return np.asarray(out, dtype=np.float32)


def make_driver(driver: str | Callable, env, *, filters: Sequence[str] = (), detector=None):
    """Build a driver by name (``"detector"`` or ``"oracle"``) or wrap a callable.

    For ``"detector"``, ``detector`` defaults to the shipped pretrained model with the
    given ``filters``.
    """
    if callable(driver) and not isinstance(driver, str):
        return CallableDriver(driver)
    check_choice("driver", driver, DRIVER_NAMES)
    if driver == "oracle":
        return MaskDriver(env)
    if detector is None:
        from simroad.detector import RoadDetector

        detector = RoadDetector.pretrained(filters=tuple(filters))
    return MaskDriver(env, detector=detector)
