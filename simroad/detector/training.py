"""Training of the detector shipped with simroad (:func:`train_default`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simroad.core.validation import normalize_rng
from simroad.detector.detector import DEFAULT_MAX_SAMPLES, DEFAULT_NONROAD_WEIGHT, RoadDetector

__all__ = ["train_default"]


def train_default(
    images: Sequence[np.ndarray], masks: Sequence[np.ndarray], *, rng: np.random.Generator | int
) -> RoadDetector:
    """Train the default detector (no filters, morphology on) as shipped with simroad:
    :data:`DEFAULT_MAX_SAMPLES` training pixels, non-road cost :data:`DEFAULT_NONROAD_WEIGHT`.

    Parameters
    ----------
    images : sequence of ndarray (H, W, 3)
        Clean RGB frames (uint8 or float in [0, 1]); use several seeds, i.e.
        several world palettes.
    masks : sequence of ndarray (H, W), bool
        Their ground-truth road masks.
    rng : numpy.random.Generator or int
        Draws the training pixels.

    Returns
    -------
    RoadDetector
        Fitted; save it with ``.save(default_model_path())``.
    """
    rng = normalize_rng(rng)
    seed = int(rng.integers(0, 2**31 - 1))
    return RoadDetector(
        (), morphology=True, max_samples=DEFAULT_MAX_SAMPLES, nonroad_weight=DEFAULT_NONROAD_WEIGHT, random_state=seed
    ).fit(images, masks)
