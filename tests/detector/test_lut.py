"""The lookup table against scikit-learn's SVC.predict (paper eq. 30)."""

from __future__ import annotations

import numpy as np

from simroad.detector import KernelExpansion
from simroad.detector.features import _features_f
from simroad.detector.lut import ColourTable, cell_centres, lut_index


def _svc_predict(det, rgb01: np.ndarray) -> np.ndarray:
    z = (_features_f(rgb01) - det.feature_mean_) / det.feature_scale_
    return det.svc_.predict(z).astype(bool)


def test_kernel_expansion_equals_svc_predict(small_detector):
    rng = np.random.default_rng(0)
    z = rng.normal(size=(5000, 3)) * 1.5
    exp = KernelExpansion.from_svc(small_detector.svc_)
    np.testing.assert_array_equal(exp.predict(z), small_detector.svc_.predict(z).astype(bool))
    np.testing.assert_allclose(exp.decision_function(z), small_detector.svc_.decision_function(z), atol=1e-9)


def test_table_equals_svc_predict_on_random_colours(small_detector):
    rng = np.random.default_rng(1)
    colours = rng.integers(0, 256, (1, 50000, 3)).astype(np.uint8)
    table = small_detector.lut_.lookup_image(colours)[0]
    np.testing.assert_array_equal(table, _svc_predict(small_detector, colours[0] / 255.0))


def test_table_equals_svc_predict_on_frame_pixels_near_the_boundary(small_detector, heldout_frames):
    det = small_detector
    pixels = np.concatenate([img.reshape(-1, 3) for img in heldout_frames[0]])
    pixels = np.unique(pixels, axis=0)[None]  # every distinct colour of 15 rendered frames
    table = det.lut_.lookup_image(pixels)[0]
    exact = _svc_predict(det, pixels[0] / 255.0)
    np.testing.assert_array_equal(table, exact)
    near = np.isin(lut_index([pixels[..., c] for c in range(3)], det.lut_.bits)[0], det.lut_.refined_cells)
    assert near.any() and (~near).any()  # both levels of the table were exercised


def test_two_level_table_on_a_known_decision():
    def decide(rgb):  # road = dark and not green
        return (rgb.sum(axis=1) < 1.2) & (rgb[:, 1] <= rgb[:, 0] + 0.05)

    table = ColourTable.build(decide, 6)
    rng = np.random.default_rng(2)
    colours = rng.integers(0, 256, (1, 100000, 3)).astype(np.uint8)
    np.testing.assert_array_equal(table.lookup_image(colours)[0], decide(colours[0] / 255.0))
    again = ColourTable.from_arrays(table.to_arrays())
    np.testing.assert_array_equal(again.coarse, table.coarse)
    np.testing.assert_array_equal(again.fine, table.fine)
    np.testing.assert_array_equal(again.refined_cells, table.refined_cells)


def test_lut_index_layout():
    img = np.array([[[0, 0, 0], [255, 255, 255], [4, 8, 12]]], np.uint8)
    idx = lut_index([img[..., c] for c in range(3)], 6)
    assert idx.tolist() == [[0, (1 << 18) - 1, (1 << 12) + (2 << 6) + 3]]
    np.testing.assert_allclose(cell_centres(6)[idx[0, 2]] * 255, [5.5, 9.5, 13.5])


def _numpy_lookup(table: ColourTable, planes: list[np.ndarray]) -> np.ndarray:
    """The table read with whole-frame integer arrays (the lookup before it was compiled)."""
    shift = 8 - table.bits
    low = np.uint8((1 << shift) - 1)
    r, g, b = planes
    sub = (((r & low).astype(np.int32) << shift | (g & low)) << shift) | (b & low)
    size = 1 << (3 * shift)
    offset = table.coarse.astype(np.int32) * size
    offset[table.refined_cells] = (2 + np.arange(len(table.refined_cells), dtype=np.int32)) * size
    flat = np.concatenate([np.zeros(size, bool), np.ones(size, bool), table.fine.reshape(-1)])
    return flat[offset[lut_index(planes, table.bits)] + sub]


def test_compiled_lookup_reads_uint8_and_float_planes_like_the_numpy_lookup():
    from simroad.filters._common import planes_to_uint8

    def decide(rgb):
        return (rgb.sum(axis=1) < 1.2) & (rgb[:, 1] <= rgb[:, 0] + 0.05)

    table = ColourTable.build(decide, 6)
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (37, 53, 3)).astype(np.uint8)
    views = [image[..., c] for c in range(3)]  # strided views, as lookup_image passes them
    np.testing.assert_array_equal(table.lookup(views), _numpy_lookup(table, views))
    # float planes, with values on and next to the rounding boundaries and a little outside [0, 1]
    halves = (rng.integers(0, 255, (3, 37, 53)) + 0.5).astype(np.float32) / np.float32(255)
    planes = [np.nextafter(h, np.float32(d)) for h, d in zip(halves, (0, 1, 0))]
    planes[2] = np.where(rng.random((37, 53)) < 0.1, np.float32(-0.01), halves[2]).astype(np.float32)
    planes[0][0, :5] = [0.0, 1.0, 1.01, -0.0, 0.5]
    np.testing.assert_array_equal(table.lookup(planes), _numpy_lookup(table, planes_to_uint8(planes)))
