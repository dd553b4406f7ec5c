"""Physical constants shared by the dynamics, the controller and the safety metrics."""

from __future__ import annotations

__all__ = ["GRAVITY_M_S2", "WATER_N"]

#: Standard gravity, m/s^2.
GRAVITY_M_S2 = 9.81
#: Refractive index of water (visible light, 20 °C).
WATER_N = 1.333
