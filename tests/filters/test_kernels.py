"""The filters' compiled loops against the numpy/OpenCV code they replace, bit for bit."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad.filters._common import to_planes
from simroad.filters._kernels import (
    LEVELS,
    MONOTONE_FROM,
    MONOTONE_POWERS,
    apply_row_tables,
    area4_floor,
    level_codes,
    median,
)
from simroad.filters.haze import _dehaze_rows, _row_floor


def _frame(rng, h=45, w=64):
    return rng.integers(0, 256, (h, w, 3)).astype(np.uint8)


def test_levels_are_the_values_to_planes_makes():
    image = np.arange(256, dtype=np.uint8).reshape(1, 256, 1).repeat(3, axis=2)
    np.testing.assert_array_equal(to_planes(image)[0][0], LEVELS)


def test_level_codes_reads_exact_levels_and_refuses_anything_else():
    rng = np.random.default_rng(0)
    image = _frame(rng)
    plane = to_planes(image)[1]
    codes = np.empty(plane.shape, np.uint8)
    assert level_codes(plane, codes)
    np.testing.assert_array_equal(codes, image[..., 1])
    for bad in (np.nextafter(plane[3, 4], np.float32(2)), np.nextafter(plane[3, 4], np.float32(-2)), 0.5, -0.25, 1.5,
                np.nan, np.inf, -np.inf):  # fmt: skip
        spoiled = plane.copy()
        spoiled[3, 4] = bad
        assert not level_codes(spoiled, codes)


@pytest.mark.parametrize("n", [1, 2, 3, 10, 11, 1760])
def test_median_is_numpys(n):
    rng = np.random.default_rng(n)
    for k in range(50):
        values = rng.random(n, dtype=np.float32) * np.float32(rng.uniform(0.01, 2.0))
        if k % 2:
            values = (np.round(values * 7) / 7).astype(np.float32)  # ties
        assert median(values) == np.median(values)
        assert median(values.reshape(1, -1)) == np.median(values.reshape(1, -1))


def test_area4_floor_is_the_reduced_darkest_channels_order_statistic():
    rng = np.random.default_rng(1)
    for h, w, k in ((1, 4, 0), (7, 40, 3), (45, 320, 2), (20, 1280, 6)):
        planes = [rng.random((h, w), dtype=np.float32) for _ in range(3)]
        planes[1][0, :8] = 0.0
        small = [cv2.resize(p, (w // 4, h), interpolation=cv2.INTER_AREA) for p in planes]
        expect = np.partition(cv2.min(cv2.min(small[0], small[1]), small[2]), k, axis=1)[:, k]
        out = np.empty(h, np.float32)
        assert not area4_floor(*planes, k, out, MONOTONE_FROM)
        np.testing.assert_array_equal(out, expect)
    planes[2][3, 8:12] = 2e-5  # a reduced value under MONOTONE_FROM is reported
    assert area4_floor(*planes, 2, out, MONOTONE_FROM)


def test_apply_row_tables():
    rng = np.random.default_rng(2)
    codes = rng.integers(0, 256, (9, 33)).astype(np.uint8)
    tables = rng.random((9, 256), dtype=np.float32)
    out = np.empty((9, 33), np.float32)
    apply_row_tables(codes, tables, out)
    np.testing.assert_array_equal(out, np.take_along_axis(tables, codes.astype(np.intp), axis=1))


@pytest.mark.parametrize("power", MONOTONE_POWERS)
def test_cv2_pow_is_a_function_of_the_value_and_monotone_above_the_bound(power):
    """The two facts the compiled paths build on, on a dense sample (every float32 of
    [0, 1] was checked once; that takes a minute)."""
    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([LEVELS, rng.uniform(MONOTONE_FROM, 1.0, 1_000_000).astype(np.float32)]))
    y = cv2.pow(x.reshape(1, -1), power).reshape(-1)
    assert (np.diff(y) >= 0).all()
    shuffled = rng.permutation(x.size)[: 7 * (x.size // 7)]  # the same values elsewhere, in other blocks
    again = cv2.pow(x[shuffled].reshape(-1, 7)[:, ::-1].copy(), power)[:, ::-1].reshape(-1)
    np.testing.assert_array_equal(again, y[shuffled])


def test_haze_rows_of_levels_are_the_literal_formula():
    rng = np.random.default_rng(4)
    for w in (64, 320):
        planes = to_planes(_frame(rng, 30, w))
        n = 17
        gain = (1.0 / np.linspace(0.5, 1.0, n, dtype=np.float32))[:, None]
        lift = np.float32(0.6) * (1.0 - gain)
        for p, gamma in zip(planes, (2.2, 2.2, 1.8)):
            out = np.full_like(p, -1.0)
            _dehaze_rows(p, out, n, gain, lift, gamma)
            lin = cv2.pow(p[:n], gamma)
            lin *= gain
            lin += lift
            np.clip(lin, 0.0, 1.0, out=lin)
            np.testing.assert_array_equal(out[:n], cv2.pow(lin, 1.0 / gamma))
            assert (out[n:] == -1.0).all()


def test_haze_row_floor_is_the_literal_order_statistic():
    rng = np.random.default_rng(5)
    for w, gamma in ((320, 2.2), (322, 2.2), (320, 2.0)):  # compiled, then two literal fallbacks
        planes = to_planes(_frame(rng, 40, w))
        planes[0][5] = 1e-5  # a row under the monotone bound: that row's floor is still exact
        sw, kth = w // 4, 2
        lin = [cv2.pow(cv2.resize(p, (sw, 40), interpolation=cv2.INTER_AREA), gamma) for p in planes]
        expect = np.partition(cv2.min(cv2.min(lin[0], lin[1]), lin[2]), kth, axis=1)[:, kth]
        np.testing.assert_array_equal(_row_floor(planes, sw, kth, gamma), expect)
