"""The control law of lane keeping: pure pursuit onto the path read from a road mask.

:class:`~simroad.control.lane_estimate.LaneEstimator` reads the ego-lane path and the
free road ahead off the mask; :class:`MaskLaneKeeper` steers onto that path with pure
pursuit and holds a target speed, lowered for short free road and for tight curves.
Given the tyre–road friction ``mu`` (the environment's ``info["mu"]``), it also
plans within its grip: it brakes and accelerates at most ``grip_use·μ·g`` and holds
the speed at which every curve it sees ahead takes at most that lateral
acceleration, ``v <= sqrt(grip_use·μ·g / κ)``.
"""

from __future__ import annotations

import math

import numpy as np

from simroad.camera.geometry import PinholeCamera
from simroad.control.autopilot import STEERING_RANGE_RAD, pure_pursuit_steering
from simroad.control.config import ControllerConfig
from simroad.control.lane_estimate import LaneEstimator, PathEstimate
from simroad.core.constants import GRAVITY_M_S2
from simroad.core.validation import check_finite_number
from simroad.envs.friction import check_mu

__all__ = ["ACCEL_RANGE_M_S2", "MaskLaneKeeper"]

#: highway-env's ContinuousAction maps acceleration action 1.0 to 5 m/s^2.
ACCEL_RANGE_M_S2 = 5.0
#: Curvature (1/m) below which the path counts as straight (no curve speed limit).
_STRAIGHT_CURVATURE_1_M = 1e-6


class MaskLaneKeeper:
    """Steer and hold speed from a bool road mask.

    Parameters
    ----------
    camera : PinholeCamera
        The calibrated camera that produced the masks (its mounting only).
    config : ControllerConfig, optional
        The controller's parameters (default ``ControllerConfig()``), shared with the
        :class:`~simroad.control.lane_estimate.LaneEstimator` that reads the masks.
    """

    def __init__(self, camera: PinholeCamera, config: ControllerConfig | None = None) -> None:
        self.estimator = LaneEstimator(camera, config)  # checks both arguments
        self.camera = camera
        self.config = self.estimator.config
        self.last: PathEstimate | None = None

    def reset(self) -> None:
        """Forget the lane index and the previous path (call at episode start)."""
        self.estimator.reset()
        self.last = None

    def read_path(self, mask: np.ndarray) -> PathEstimate:
        """Measure road edges on the look-ahead rows and the ego-lane centre line
        (see :meth:`LaneEstimator.read_path`)."""
        return self.estimator.read_path(mask)

    def act(self, mask: np.ndarray, speed_m_s: float, *, mu: float | None = None) -> np.ndarray:
        """Return ``[steering, acceleration]`` actions in [-1, 1] for highway-env.

        Parameters
        ----------
        mask : ndarray of bool, shape (H, W)
            Road mask of the camera frame.
        speed_m_s : float
            The ego's speed in m/s.
        mu : float, optional
            Tyre–road friction coefficient under the car (``info["mu"]``); None
            plans without a grip limit.

        Returns
        -------
        ndarray of float32, shape (2,)
        """
        check_finite_number("speed_m_s", speed_m_s)
        grip = math.inf if mu is None else self.config.grip_use * check_mu("mu", mu) * GRAVITY_M_S2
        est = self.estimator.read_path(mask)
        self.last = est
        self.estimator.remember(est)
        c = self.config
        ld = float(np.clip(c.lookahead_time_s * speed_m_s, c.min_lookahead_m, c.max_lookahead_m))
        if len(est.x_m):  # stay on the measured part of the path: never extrapolate
            ld = float(np.clip(ld, est.x_m.min(), est.x_m.max()))
        target = np.array([ld, float(np.polyval(est.coeffs, ld))])
        # Pure pursuit from the rear axle: in highway-env's kinematic bicycle (centre of
        # gravity midway, sideslip beta) only the rear axle moves along the heading.
        delta = pure_pursuit_steering((-c.wheelbase_m / 2.0, 0.0, 0.0), target, c.wheelbase_m)
        steer = float(np.clip(delta / STEERING_RANGE_RAD, -1.0, 1.0))
        decel = min(c.max_decel_m_s2, grip)
        safe = math.sqrt(2.0 * decel * max(0.0, est.free_road_m - c.stop_margin_m))
        # Curvature of the arc pure pursuit will drive (bounded by geometry, unlike the
        # second derivative of a fitted polynomial).
        rear = np.array([-c.wheelbase_m / 2.0, 0.0])
        d = target - rear
        kappa = abs(2.0 * d[1]) / float(d @ d)
        curve = math.sqrt(c.max_lateral_accel_m_s2 / kappa) if kappa > _STRAIGHT_CURVATURE_1_M else math.inf
        v_des = min(c.target_speed_m_s, safe, curve, _grip_speed(est, rear, grip))
        accel = np.clip(c.speed_gain_1_s * (v_des - speed_m_s), -decel, min(c.max_accel_m_s2, grip))
        return np.array([steer, float(accel) / ACCEL_RANGE_M_S2], dtype=np.float32)


def _grip_speed(est: PathEstimate, rear: np.ndarray, lateral_m_s2: float) -> float:
    """Highest speed at which every arc from the rear axle to a measured point of the
    path ahead takes at most ``lateral_m_s2`` (m/s; inf on a straight or without grip limit)."""
    if not math.isfinite(lateral_m_s2) or not len(est.x_m):
        return math.inf
    d = np.stack([est.x_m - rear[0], np.polyval(est.coeffs, est.x_m) - rear[1]], axis=1)
    kappa = float(np.max(np.abs(2.0 * d[:, 1]) / np.einsum("ij,ij->i", d, d)))
    return math.sqrt(lateral_m_s2 / kappa) if kappa > _STRAIGHT_CURVATURE_1_M else math.inf
