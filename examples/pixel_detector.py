"""A user's own road detector for simroad: a scikit-learn pixel classifier (cubic
logistic regression) on CIE Lab colour and the pixel's place in the image, trained on
simroad's clean frames of worlds 0-3.

    simroad episode --detector examples/pixel_detector.py:LabPixelDetector
    simroad ablate --detectors paper,examples/pixel_detector.py:LabPixelDetector ...
    simroad evaluate-detector --detector examples/pixel_detector.py:LabPixelDetector
"""

import cv2
import numpy as np
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from simroad.experiments.frames import collect_frames


class LabPixelDetector:
    name = "lab-pixels"
    version = "1"

    def __init__(self, seeds: int = 4, frames: int = 6, samples: int = 60000, seed: int = 0) -> None:
        data = collect_frames(seeds=range(seeds), frames_per_seed=frames)  # worlds 0.., every scenario
        rng = np.random.default_rng(seed)
        per_frame = samples // len(data.images)
        x, y = [], []
        for image, road, valid in zip(data.images, data.masks, data.valid):
            pick = rng.choice(np.flatnonzero(valid), size=per_frame, replace=False)
            x.append(self.features(image)[pick])
            y.append(road.ravel()[pick])
        self.model = make_pipeline(StandardScaler(), PolynomialFeatures(3), LogisticRegression(max_iter=500))
        self.model.fit(np.concatenate(x), np.concatenate(y))

    @staticmethod
    def features(image: np.ndarray) -> np.ndarray:
        h, w = image.shape[:2]
        lab = cv2.cvtColor(image, cv2.COLOR_RGB2LAB).reshape(-1, 3).astype(np.float32)
        row = np.repeat(np.linspace(0.0, 1.0, h, dtype=np.float32), w)
        col = np.tile(np.abs(np.linspace(-1.0, 1.0, w, dtype=np.float32)), h)  # distance from the centre
        return np.column_stack([lab, row, col])

    def predict(self, image: np.ndarray) -> np.ndarray:
        return self.model.predict(self.features(image)).reshape(image.shape[:2]).astype(bool)
