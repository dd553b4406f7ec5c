"""The paper's road detector (§III): features, SVM segmentation, lookup table, morphology."""

from __future__ import annotations

from simroad.detector.detector import MIN_IMAGE_SIZE, RoadDetector, default_model_path
from simroad.detector.features import hsi, pixel_features
from simroad.detector.morphology import extend_upward, fill_holes, keep_ego_component, postprocess
from simroad.detector.persistence import check_model_destination
from simroad.detector.svm import KernelExpansion
from simroad.detector.training import train_default
from simroad.filters import FILTERS, apply_filters  # re-exported: filters are run by name from simroad.filters

__all__ = [
    "FILTERS",
    "MIN_IMAGE_SIZE",
    "KernelExpansion",
    "RoadDetector",
    "apply_filters",
    "check_model_destination",
    "default_model_path",
    "extend_upward",
    "fill_holes",
    "hsi",
    "keep_ego_component",
    "pixel_features",
    "postprocess",
    "train_default",
]
