"""The lookup table against scikit-learn's SVC.predict (paper eq. 30)."""

from __future__ import annotations

import numpy as np

from simroad.detector import KernelExpansion
from simroad.detector.features import _features_f
from simroad.detector.lut import cell_centres, lut_index, pack_lut, unpack_lut


def _svc_predict(det, rgb01: np.ndarray) -> np.ndarray:
    z = (_features_f(rgb01) - det.feature_mean_) / det.feature_scale_
    return det.svc_.predict(z).astype(bool)


def test_kernel_expansion_equals_svc_predict(small_detector):
    rng = np.random.default_rng(0)
    z = rng.normal(size=(5000, 3)) * 1.5
    exp = KernelExpansion.from_svc(small_detector.svc_)
    np.testing.assert_array_equal(exp.predict(z), small_detector.svc_.predict(z).astype(bool))
    np.testing.assert_allclose(exp.decision_function(z), small_detector.svc_.decision_function(z), atol=1e-9)


def test_table_equals_svc_predict_at_random_cells(small_detector):
    det = small_detector
    bits = det.lut_bits_
    rng = np.random.default_rng(1)
    cells = rng.integers(0, 1 << (3 * bits), 4000)
    np.testing.assert_array_equal(det.lut_[cells], _svc_predict(det, cell_centres(bits)[cells]))


def test_table_agrees_with_svc_predict_on_random_pixels(small_detector, heldout_frames):
    det = small_detector
    rng = np.random.default_rng(2)
    pixels = np.concatenate([img.reshape(-1, 3) for img in heldout_frames[0]])
    pixels = pixels[rng.choice(len(pixels), 20000, replace=False)]
    planes = [pixels[:, c].reshape(1, -1) for c in range(3)]
    table = det.lut_[lut_index(planes, det.lut_bits_)[0]]
    exact = _svc_predict(det, pixels / 255.0)
    assert (table == exact).mean() > 0.98  # only colours within half a cell of the boundary differ


def test_lut_index_layout_and_packing():
    img = np.array([[[0, 0, 0], [255, 255, 255], [4, 8, 12]]], np.uint8)
    idx = lut_index([img[..., c] for c in range(3)], 6)
    assert idx.tolist() == [[0, (1 << 18) - 1, (1 << 12) + (2 << 6) + 3]]
    centres = cell_centres(6)
    np.testing.assert_allclose(centres[idx[0, 2]] * 255, [5.5, 9.5, 13.5])
    table = np.random.default_rng(3).random(1 << 15) < 0.5
    np.testing.assert_array_equal(unpack_lut(pack_lut(table), 5), table)
