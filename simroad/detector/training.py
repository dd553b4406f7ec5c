"""Training of the detector shipped with simroad (:func:`train_default`) and its settings."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simroad.core.validation import normalize_rng
from simroad.detector.detector import RoadDetector

__all__ = ["SHIPPED_MAX_SAMPLES", "SHIPPED_NONROAD_WEIGHT", "SHIPPED_NORMALIZE", "train_default"]

#: The shipped model's training settings (``simroad/data/road_detector.npz``, stored in
#: it as its ``max_samples`` and ``nonroad_weight``): 16000 training pixels, and a
#: non-road pixel weighing twice a road pixel. With them the clean-frame FPR of held-out
#: worlds fell from 3.6 % to under 2 % for FNR 1.5 % -> about 2 % (README, "The shipped
#: model"). ``RoadDetector``'s own default ``max_samples`` is the same 16000; its
#: default ``nonroad_weight`` is 1.
SHIPPED_MAX_SAMPLES = 16000
SHIPPED_NONROAD_WEIGHT = 2.0
#: The shipped model classifies colours relative to the road ahead
#: (:mod:`simroad.detector.reference`): a camera's exposure and white balance move the
#: same asphalt from V 0.12 to 0.42 between scenes, and pale verges fall inside that range.
SHIPPED_NORMALIZE = "road_ahead"


def train_default(
    images: Sequence[np.ndarray], masks: Sequence[np.ndarray], *, rng: np.random.Generator | int
) -> RoadDetector:
    """Train the default detector (no filters, morphology on) as shipped with simroad:
    :data:`SHIPPED_MAX_SAMPLES` training pixels, non-road cost :data:`SHIPPED_NONROAD_WEIGHT`,
    colours relative to the road ahead (:data:`SHIPPED_NORMALIZE`).

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
        filters=(), morphology=True, max_samples=SHIPPED_MAX_SAMPLES, nonroad_weight=SHIPPED_NONROAD_WEIGHT,
        normalize=SHIPPED_NORMALIZE, random_state=seed,
    ).fit(images, masks)  # fmt: skip
