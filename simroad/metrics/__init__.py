"""Scoring of episodes: road-mask metrics and driving-safety metrics.

Mask metrics follow paper eqs. 32-33, pooled and per frame; safety metrics are
computed from highway-env's state.
"""

from __future__ import annotations

from simroad.metrics.mask import MaskScore, confusion, error_rates, rates_from_counts
from simroad.metrics.safety import PENALTIES, SafetyScore, footprint_corners

__all__ = [
    "PENALTIES",
    "MaskScore",
    "SafetyScore",
    "confusion",
    "error_rates",
    "footprint_corners",
    "rates_from_counts",
]
