"""The wiper: when its blade is where, which drops it sweeps, and how it looks.

Pure functions for :mod:`simroad.noise.windscreen`. The blade turns about a pivot on
the glass (glass coordinates, m; see :mod:`simroad.noise._glass`); its angle ``α`` is
measured from the glass's +gx axis (to the right), counter-clockwise seen from the
camera. One wipe cycle is an up-stroke from the rest angle 0 to ``arc`` and a
down-stroke back, each ``stroke_s`` long with the smooth (cosine) speed profile of a
crank-driven linkage; cycles start every period (or when the rain sensor asks).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["blade_angle", "blade_coverage", "swept_interval"]


def blade_angle(tau_s: float, stroke_s: float, arc_rad: float) -> float:
    """Blade angle (rad) ``tau_s`` seconds into a wipe cycle (0 outside the cycle)."""
    if tau_s <= 0.0 or tau_s >= 2.0 * stroke_s:
        return 0.0
    return 0.5 * arc_rad * (1.0 - math.cos(math.pi * tau_s / stroke_s))


def swept_interval(tau0_s: float, tau1_s: float, stroke_s: float, arc_rad: float) -> tuple[float, float] | None:
    """Blade angles ``[lo, hi]`` swept between ``tau0_s`` and ``tau1_s`` of one cycle.

    The blade's angle is monotonic within each stroke, so the extremes of the interval
    are its ends or the turning point (``arc`` at ``stroke_s``). ``None`` if the blade
    rests throughout.
    """
    a = max(tau0_s, 0.0)
    b = min(tau1_s, 2.0 * stroke_s)
    if b <= a:
        return None
    angles = [blade_angle(a, stroke_s, arc_rad), blade_angle(b, stroke_s, arc_rad)]
    if a < stroke_s < b:
        angles.append(arc_rad)
    if max(angles) <= 0.0:
        return None
    return min(angles), max(angles)


def blade_coverage(
    rel_x: np.ndarray,
    rel_y: np.ndarray,
    angle_rad: float,
    *,
    width_m: float,
    length_m: float,
    edge_m: float,
) -> np.ndarray:
    """Fraction of each pixel the blade hides, float32 (H, W).

    Parameters
    ----------
    rel_x, rel_y : ndarray float32 (H, W)
        Glass coordinates of each pixel relative to the pivot, m.
    angle_rad : float
        Blade angle α.
    width_m, length_m : float
        The blade's visible width and its reach from the pivot, m.
    edge_m : float
        Width of the blade's soft edge on the glass, m: the defocus blur (about the
        lens aperture for a glass close to the lens, see :mod:`simroad.noise._glass`).
    """
    ca, sa = math.cos(angle_rad), math.sin(angle_rad)
    across = cv2.addWeighted(rel_y, ca, rel_x, -sa, 0.0)  # distance from the blade's line
    along = cv2.addWeighted(rel_x, ca, rel_y, sa, 0.0)  # distance along it from the pivot
    edge = max(edge_m, 1e-6)
    cov = (0.5 * width_m + 0.5 * edge - np.abs(across)) / edge
    reach = (length_m - along) / edge + 0.5
    return np.clip(np.minimum(np.minimum(cov, reach), along / edge), 0.0, 1.0).astype(np.float32)
