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

from simroad.camera.geometry import PinholeCamera
from simroad.control.config import ControllerConfig
from simroad.control.lane_keeping import MaskLaneKeeper
from simroad.core.validation import check_choice
from simroad.detector.registry import load_detector, predict_checked, start_episode
from simroad.envs import RoadCamEnv
from simroad.envs.scenarios import get_scenario
from simroad.errors import InvalidParameterError

__all__ = ["DRIVER_NAMES", "CallableDriver", "MaskDriver", "make_driver"]

DRIVER_NAMES = ("detector", "oracle")


class MaskDriver:
    """Lane keeping from a road mask: predicted (detector) or ground truth (oracle).

    Parameters
    ----------
    camera : PinholeCamera
        The calibrated camera that produced the frames (its mounting only).
    control : ControllerConfig
        The controller's parameters, e.g. ``ControllerConfig.for_scenario(spec)``.
    detector : object with ``predict(uint8 (H, W, 3)) -> bool (H, W)``, optional
        None means the oracle: the mask is ``info["road_mask"]``.

    Attributes
    ----------
    episode : object with ``predict`` or None
        The detector's current episode (:func:`~simroad.detector.registry.start_episode`
        with ``camera``): :meth:`reset` starts one, the first call does if no reset did.
        It carries what persists across the episode's frames (for the shipped detector,
        the camera's ground mask and the glare memory); the detector itself is shared.
    last_mask : ndarray, bool, (H, W), or None
        The mask of the last call.

    Actions are ``[steering, acceleration]``: the environment must be created with
    ``longitudinal=True`` (:func:`make_driver` checks it).
    """

    def __init__(self, camera: PinholeCamera, control: ControllerConfig, *, detector: Any = None) -> None:
        if not isinstance(camera, PinholeCamera):
            raise InvalidParameterError(f"camera: expected a PinholeCamera (env.camera), got {type(camera).__name__}.")
        if not isinstance(control, ControllerConfig):
            raise InvalidParameterError(
                f"control: expected a ControllerConfig (ControllerConfig.for_scenario(spec)), "
                f"got {type(control).__name__}."
            )
        self.detector = detector
        self.camera = camera
        self.controller = MaskLaneKeeper(camera, control)
        self.episode: Any = None
        self.last_mask: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the controller's memory of the previous episode, and start the
        detector's episode with the camera (:func:`~simroad.detector.registry.start_episode`:
        its ``episode(camera)``, else its ``reset()`` and ``set_camera(camera)``, where it
        has them; a detector built once per process may have seen another camera before)."""
        self.controller.reset()
        self.episode = None if self.detector is None else start_episode(self.detector, self.camera)

    def __call__(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        if self.detector is None:
            mask = info["road_mask"]
        else:
            if self.episode is None:
                self.episode = start_episode(self.detector, self.camera)
            mask = predict_checked(self.episode, obs, self.detector)
        self.last_mask = mask
        return self.controller.act(mask, float(info["speed_m_s"]), mu=info.get("mu"))


class CallableDriver:
    """Wrap a user callable ``obs -> action``; its predicted mask, if it returns
    ``(action, mask)``, is scored like the detector's."""

    def __init__(self, fn: Callable[[np.ndarray], Any]) -> None:
        if not callable(fn):
            raise InvalidParameterError(
                f"driver: expected 'detector', 'oracle' or a callable obs -> action, got {fn!r}."
            )
        self.fn = fn
        self.last_mask: np.ndarray | None = None

    def reset(self) -> None:
        """Call the wrapped callable's ``reset()``, if it has one."""
        reset = getattr(self.fn, "reset", None)
        if callable(reset):
            reset()

    def __call__(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        out = self.fn(obs)
        if isinstance(out, tuple) and len(out) == 2:
            out, self.last_mask = out
        try:
            return np.asarray(out, dtype=np.float32)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"driver: returned {type(out).__name__} {out!r:.80}, expected an action: numbers such as "
                "[steering, acceleration] in [-1, 1] (or (action, mask))."
            ) from None


def make_driver(
    driver: str | Callable,
    env: Any,
    *,
    filters: Sequence[str] = (),
    detector: Any = None,
    control: ControllerConfig | None = None,
) -> MaskDriver | CallableDriver:
    """Build a driver by name (``"detector"`` or ``"oracle"``) or wrap a callable.

    A convenience over :class:`MaskDriver`: it takes the camera and the scenario
    (``ControllerConfig.for_scenario``, unless ``control`` is given) from ``env``, an
    unwrapped :class:`~simroad.envs.RoadCamEnv` created with ``longitudinal=True``.
    For ``"detector"``, ``detector`` (any object with ``predict``, see
    :mod:`simroad.detector.registry`) defaults to the shipped ``paper`` model with
    the given ``filters``.
    """
    if callable(driver) and not isinstance(driver, str):
        return CallableDriver(driver)
    check_choice("driver", driver, DRIVER_NAMES)

    if not isinstance(getattr(env, "unwrapped", env), RoadCamEnv):
        raise InvalidParameterError(
            f"env: expected a RoadCamEnv (e.g. gymnasium.make(...).unwrapped), got {type(env).__name__}."
        )
    env = env.unwrapped
    if not env.config.longitudinal:
        raise InvalidParameterError(
            "env: mask drivers control speed too; create the environment with longitudinal=True."
        )
    if control is None:
        control = ControllerConfig.for_scenario(get_scenario(env.config.scenario))
    if driver == "oracle":
        return MaskDriver(env.camera, control)
    if detector is None:
        detector = load_detector("paper", filters=tuple(filters))
    elif not callable(getattr(detector, "predict", None)):
        raise InvalidParameterError(
            f"detector: expected an object with predict(uint8 (H, W, 3)) -> bool (H, W), got {type(detector).__name__}."
        )
    return MaskDriver(env.camera, control, detector=detector)
