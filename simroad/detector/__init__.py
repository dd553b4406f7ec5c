"""The paper's road detector (§III): features, SVM segmentation, lookup table, morphology."""

from __future__ import annotations

from simroad.detector.detector import RoadDetector, default_model_path
from simroad.detector.episode import DetectorEpisode, GlareMemory
from simroad.detector.features import hsi, pixel_features
from simroad.detector.morphology import extend_upward, fill_holes, keep_ego_component, postprocess
from simroad.detector.persistence import check_model_destination
from simroad.detector.pixels import MIN_IMAGE_SIZE
from simroad.detector.svm import KernelExpansion
from simroad.detector.training import train_default

__all__ = [
    "MIN_IMAGE_SIZE",
    "DetectorEpisode",
    "GlareMemory",
    "KernelExpansion",
    "RoadDetector",
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
