"""Scoring of episodes: road-mask metrics (paper eqs. 32-33, pooled and per frame).

The driving-safety metrics read highway-env's state and live in
:mod:`simroad.metrics.safety`, imported on its own so that scoring masks loads no
simulator.
"""

from __future__ import annotations

from simroad.metrics.mask import MaskScore, confusion, error_rates, rates_from_counts

__all__ = ["MaskScore", "confusion", "error_rates", "rates_from_counts"]
