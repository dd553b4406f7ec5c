"""Scoring: road-mask metrics (paper eqs. 32-33), pooled and per frame."""

from __future__ import annotations

from simroad.metrics.mask import MaskScore, confusion, error_rates, rates_from_counts

__all__ = ["MaskScore", "confusion", "error_rates", "rates_from_counts"]
