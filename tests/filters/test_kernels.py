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
    masked_medians,
    median,
    median_at_most,
    percentile_below,
    quantize_take,
)
from simroad.filters._plane_kernels import isotonic_increasing
from simroad.filters._relight_kernels import edge_pairs
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


# ------------------------------------------------ relight and glare: compiled vs numpy


def _linearise_reference(p, table):
    return table.take(np.clip(np.rint(p * (table.size - 1)), 0, table.size - 1).astype(np.intp))


def test_quantize_take_is_the_rounded_table_read():
    rng = np.random.default_rng(6)
    table = rng.random(4096, dtype=np.float32)
    p = rng.random((40, 50), dtype=np.float32)
    p[0, :8] = [0.0, 1.0, -0.5, 1.5, np.float32(0.5 / 4095), np.float32(1.5 / 4095), np.float32(2.5 / 4095), -0.0]
    out = np.empty_like(p)
    quantize_take(p, table, out)
    np.testing.assert_array_equal(out, _linearise_reference(p, table))


def test_sky_test_is_the_median_log_ratio_against_the_threshold():
    from simroad.filters.relight import _linear_table, _sky_not_blue

    rng = np.random.default_rng(7)
    table = _linear_table(1.0)
    for _k in range(40):
        planes = to_planes(_frame(rng, 40, 48))
        planes[2] *= np.float32(rng.uniform(0.5, 1.5))
        np.clip(planes[2], 0, 1, out=planes[2])
        top = 10
        r, g, b = (_linearise_reference(p[:top], table) for p in planes)
        ok = (np.maximum(np.maximum(r, g), b) < 0.97) & (r > 0.03) & (b > 2e-3)
        blue = float(np.median(np.log(b[ok] / r[ok]))) if ok.sum() >= 30 else -np.inf
        for t in (blue, np.nextafter(blue, 1.0), np.nextafter(blue, -1.0), 0.25, -0.1):
            assert _sky_not_blue(planes, table, 0.25, t) == (blue <= t)


def test_edge_pairs_lists_the_numpy_pairs_in_order():
    rng = np.random.default_rng(8)
    logs = (rng.normal(-1.0, 0.6, (3, 30, 41))).astype(np.float32)
    valid = rng.random((30, 41)) < 0.9
    got = edge_pairs(logs, valid, 4, np.float32(0.5), np.float32(0.25))
    expect = []
    for dy, dx in ((0, 4), (4, 0)):
        h, w = valid.shape
        a, b = logs[:, : h - dy, : w - dx], logs[:, dy:, dx:]
        both = valid[: h - dy, : w - dx] & valid[dy:, dx:]
        for diff in (b - a, a - b):
            r, g, bl = diff
            ok = both & (r < -0.5) & (r < g) & (g < bl) & (bl < 0.0) & (bl - r > 0.25 * -r)
            expect.append(diff[:, ok].T)
    expect = np.concatenate(expect)
    assert len(expect) > 20
    np.testing.assert_array_equal(got, expect)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_masked_medians_and_median_at_most(dtype):
    rng = np.random.default_rng(9)
    x = (np.round(rng.normal(size=(3, 20, 30)) * 8) / 8).astype(dtype)
    for _k in range(20):
        mask = rng.random((20, 30)) < rng.uniform(0.005, 0.9)
        if not mask.any():
            continue
        np.testing.assert_array_equal(masked_medians(x, mask), np.median(x[:, mask], axis=1))
    values = x[0].reshape(-1).astype(np.float32)
    for t in np.concatenate([values[:50], [0.0625, -3.0, 3.0]]):
        for n in (len(values), len(values) - 1):
            assert median_at_most(values[:n], float(t)) == (float(np.median(values[:n])) <= float(t))


def test_percentile_decision_is_numpys():
    rng = np.random.default_rng(10)
    for _k in range(500):
        x = (np.round(rng.random(int(rng.integers(1, 200))) * 30) / 30).astype(np.float32)
        for t in (float(rng.choice(x)), 0.5, float(rng.choice(x)) + 1e-9):
            assert percentile_below(x, 99, t) == (float(np.percentile(x, 99)) < t)


def _fill_rows_reference(lin, holes):
    from simroad.filters._common import crop_box

    rows, cols = crop_box(holes, 1)
    sub = holes[rows, cols]
    w = sub.shape[1]
    col = np.arange(w)
    left = np.maximum.accumulate(np.where(sub, -1, col), axis=1)
    right = np.minimum.accumulate(np.where(sub, w, col)[:, ::-1], axis=1)[:, ::-1]
    left_ok, right_ok = left >= 0, right < w
    li = np.where(left_ok, left, np.where(right_ok, right, 0))
    ri = np.where(right_ok, right, li)
    frac = ((col - li) / np.maximum(ri - li, 1)).astype(np.float32)
    for p in lin:
        box = p[rows, cols]
        a, b = np.take_along_axis(box, li, axis=1), np.take_along_axis(box, ri, axis=1)
        np.copyto(box, a + (b - a) * frac, where=sub)


def test_fill_rows_is_the_numpy_interpolation():
    from simroad.filters.glare import _fill_rows

    rng = np.random.default_rng(11)
    for k in range(30):
        lin = rng.random((3, 25, 37), dtype=np.float32)
        holes = cv2.dilate((rng.random((25, 37)) < 0.05).view(np.uint8), np.ones((1, 5), np.uint8)).astype(bool)
        if k == 0:
            holes[3] = True  # a whole row
            holes[:, 0] = True  # the left border
        expect = [p.copy() for p in lin]
        _fill_rows_reference(expect, holes)
        _fill_rows(lin, holes)
        np.testing.assert_array_equal(lin, np.stack(expect))


def test_clipped_core_is_the_numpy_one():
    from simroad.filters.glare import _CLIP_DEPTH, _CLIP_SPREAD, _clipped

    rng = np.random.default_rng(12)
    for k in range(30):
        planes = [rng.random((20, 30), dtype=np.float32) for _ in range(3)]
        if k % 2:
            planes[1][5:9, 5:15] = planes[0][5:9, 5:15] = planes[2][5:9, 5:15] = 0.99  # a grey top
        lobe = rng.random((20, 30)) < 0.4
        hi = cv2.max(cv2.max(planes[0], planes[1]), planes[2])
        top = lobe & (hi >= float(hi[lobe].max()) - _CLIP_DEPTH)
        grey = (hi - cv2.min(cv2.min(planes[0], planes[1]), planes[2])) <= _CLIP_SPREAD
        expect = top if 2 * int((top & grey).sum()) >= int(top.sum()) else np.zeros_like(lobe)
        np.testing.assert_array_equal(_clipped(planes, lobe), expect)


def test_lit_diff_is_the_per_channel_computation():
    from simroad.filters.relight import _lit_diff

    rng = np.random.default_rng(13)
    logs = np.log(rng.uniform(2e-3, 1.0, (3, 54, 160))).astype(np.float32)
    sparse = np.zeros((54, 160))
    sparse[10:20, 30:45] = 1.0  # one lit patch: pixels far from it fall back to the frame's mean
    for lit in (
        (rng.random((54, 160)) < 0.7).astype(np.float32),
        (rng.random((54, 160)) < 0.3) * np.float64(1),
        sparse,
    ):
        expect = np.repeat((logs * lit).sum(axis=(1, 2))[:, None, None] / max(float(lit.sum()), 1.0), 54, 1)
        expect = np.repeat(expect, 160, 2)
        for size in (93, 31):
            weight = cv2.blur(lit, (size, size))
            ok = weight > 0.15
            for c in range(3):
                np.copyto(expect[c], cv2.blur(logs[c] * lit, (size, size)) / np.maximum(weight, 1e-6), where=ok)
        got = _lit_diff(logs, lit, 31)
        assert got.dtype == (logs - expect).dtype
        np.testing.assert_array_equal(got, logs - expect)


def test_camera_response_is_the_float32_formula():
    from simroad.core.radiometry import CAMERA_TONE_GAMMA, GAMMA
    from simroad.filters._common import camera_to_linear, linear_to_camera

    encode = CAMERA_TONE_GAMMA / GAMMA  # the camera's tone exponent, then the display encoding
    rng = np.random.default_rng(14)
    for shape in ((30, 40), (7,), (1, 256)):
        for k in (1.0, 0.0, 3.7):
            p = rng.random(shape, dtype=np.float32)
            z = cv2.pow(p, 1.0 / encode)
            np.testing.assert_array_equal(camera_to_linear(p, k), z / (np.float32(1 + k) - np.float32(k) * z))
            y = (rng.random(shape) * 1.4 - 0.2).astype(np.float32)
            for gain in (None, np.float32(1.37)):
                c = np.clip(y if gain is None else y * gain, 0.0, 1.0)
                expect = cv2.pow(np.float32(1 + k) * c / (np.float32(1) + np.float32(k) * c), encode)
                np.testing.assert_array_equal(linear_to_camera(y, k, gain=gain), expect)


def test_glare_linear_planes_and_reexposure_of_level_and_other_rows():
    from simroad.filters._common import camera_to_linear, linear_to_camera
    from simroad.filters.glare import _reexpose, _to_linear

    rng = np.random.default_rng(15)
    planes = to_planes(_frame(rng, 40, 50))
    for p in planes:
        p[3:11] *= np.float32(0.93)  # rows that are no longer 8-bit levels (as after the haze step)
    lin, codes, rows = _to_linear(planes, 1.0)
    np.testing.assert_array_equal(lin, np.stack([camera_to_linear(p, 1.0) for p in planes]))
    assert not rows[:, 3:11].any() and rows[:, 11:].all()
    gain = np.float32(1.6)
    lin[:, 20:] *= np.float32(0.8)  # the lobe rows change
    got = _reexpose(lin, gain, codes, rows, 20, 1.0, [None] * 3)
    np.testing.assert_array_equal(np.stack(got), np.stack([linear_to_camera(x * gain, 1.0) for x in lin]))


def test_linear_halves_is_the_area_halving_of_the_linear_plane():
    from simroad.filters._kernels import linear_halves

    rng = np.random.default_rng(16)
    table = rng.random(4096, dtype=np.float32)
    for h, w in ((108, 320), (10, 14), (6, 18), (4, 322), (2, 2)):  # vector loop and scalar tail
        p = rng.random((h, w), dtype=np.float32)
        lin = np.empty_like(p)
        quantize_take(p, table, lin)
        out = np.empty((h // 2, w // 2), np.float32)
        linear_halves(p, table, out)
        np.testing.assert_array_equal(out, cv2.resize(lin, (w // 2, h // 2), interpolation=cv2.INTER_AREA))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("k", [3, 5, 9, 32, 31])
def test_lit_diff_boxes_are_cv2_blur_of_the_weighted_logs(dtype, k):
    from simroad.filters._lit_boxes import lit_diff

    rng = np.random.default_rng(k)
    for h, w in ((54, 160), (5, 40), (30, 7)):
        logs = np.log(rng.uniform(2e-3, 1.0, (3, h, w))).astype(np.float32)
        logs.reshape(-1)[::11] = np.float32(-1e-7)  # sums that are not exact in float64: the order shows
        for density in (0.6, 0.15, 0.05, -0.6):  # across the columns, from none: each box holds enough, or neither
            lit = (rng.random((h, w)) < abs(density) * np.linspace(0.0, 2.0, w)).astype(dtype)
            if density < 0:  # a gap in the middle: the larger box is needed in some middle columns only
                lit[:, w // 3 : w // 2 + 1] = 0
            mean = np.zeros((3, h, w), dtype)
            held = np.zeros((h, w), bool)
            for size in (3 * k, k):  # the smaller box overrides the larger where it holds enough
                sums = cv2.blur(np.dstack([lit, *(logs * lit)]), (size, size))
                ok = sums[..., 0] > dtype(0.15)
                held |= ok
                for c in range(3):
                    np.copyto(mean[c], sums[..., c + 1] / np.maximum(sums[..., 0], dtype(1e-6)), where=ok)
            for eager in (True, False):  # both boxes' row sums at once, or the larger's where needed
                got, rest = np.empty((3, h, w), dtype), np.empty((h, w), np.uint8)
                sums = np.empty((2, h, 4, w), np.float64)
                n = lit_diff(logs, lit, (k, 3 * k), dtype(0.15), dtype(1e-6), got, rest, sums, eager)
                assert n == (~held).sum()
                np.testing.assert_array_equal(rest == 2, ~held)
                np.testing.assert_array_equal(got, logs - mean)  # mean 0 where neither holds enough


@pytest.mark.parametrize("dtypes", [(np.float32, np.float32), (np.float32, np.float64), (np.float64, np.float64)])
def test_projections_are_the_three_products_summed_in_order(dtypes):
    from simroad.filters._relight_kernels import alpha_chroma, project

    rng = np.random.default_rng(18)
    kind_d, kind_x = dtypes
    x = rng.normal(-0.3, 0.5, (3, 54, 160)).astype(kind_x)
    x[:, 0, :5] = 0.0
    d = np.array([-0.9, -0.7, -0.45], kind_d) * kind_d(rng.uniform(0.5, 1.5))
    dc = d - d.mean()
    dd, dcc = np.float32(d @ d), np.float32(dc @ dc)

    def reference(v, y, den):
        return ((v[0] * y[0] + v[1] * y[1]) + v[2] * y[2]).astype(np.float32) / den

    alpha, chroma = np.empty((54, 160), np.float32), np.empty((54, 160), np.float32)
    alpha_chroma(x, d, dd, dc, dcc, alpha, chroma)
    np.testing.assert_array_equal(alpha, reference(d, x, dd))
    np.testing.assert_array_equal(chroma, reference(dc, x - x.mean(axis=0), dcc))
    out = np.empty((54, 160), np.float32)
    project(x, d, -dd, out)
    np.testing.assert_array_equal(out, -reference(d, x, dd))  # x / -y is -(x / y)
    # np.tensordot (BLAS) sums the same products in the same order (bit for bit with this
    # machine's OpenBLAS); another BLAS may round differently, so within a tolerance here
    tensordot = np.tensordot(d, x, 1).astype(np.float32) / dd
    np.testing.assert_allclose(alpha, tensordot, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(chroma, np.tensordot(dc, x - x.mean(axis=0), 1).astype(np.float32) / dcc,
                               rtol=1e-6, atol=1e-6)  # fmt: skip


def test_strong_median_is_the_median_of_the_pairs_over_the_percentile():
    from simroad.filters._relight_kernels import _percentile, strong_median

    rng = np.random.default_rng(19)
    for k in range(400):
        n = int(rng.integers(1, 300))
        pairs = -rng.random((n, 3), dtype=np.float32) * np.float32(rng.uniform(0.5, 3.0))
        if k % 3 == 1:
            pairs = (np.round(pairs * 7) / 7).astype(np.float32)  # ties
        if k % 3 == 2:  # neighbours an ulp or a few apart: the interpolation's rounding shows
            pairs[:, 0] = np.float32(-1.5) - np.arange(n, dtype=np.float32) * np.spacing(np.float32(1.5)) * (k % 4)
        drop = -pairs[:, 0]
        for q in (75.0, 50.0, 90.0, 0.0, 100.0):
            assert _percentile(drop.copy(), q) == np.percentile(drop, q)
        expect = np.median(pairs[drop >= np.percentile(drop, 75)], axis=0)
        np.testing.assert_array_equal(strong_median(pairs, 75.0), expect)


@pytest.mark.parametrize("kinds", [(np.float32, np.float32), (np.float64, np.float32), (np.float64, np.float64)])
def test_next_direction_is_the_capped_median_over_the_cores(kinds):
    from simroad.filters._relight_kernels import next_direction

    kind, kind_d = kinds
    rng = np.random.default_rng(20)
    diff = (np.round(rng.normal(-0.5, 0.4, (3, 20, 30)) * 16) / 16).astype(kind)  # ties
    for k in range(40):
        core = (rng.random((20, 30)) < rng.uniform(0.0, 0.5)).astype(np.uint8) * np.uint8(1 + k % 2)
        d = rng.normal(-0.5, 0.2, 3).astype(kind_d)
        new = np.full(3, np.nan, kind)
        count, moved = next_direction(diff, core, d, 20, kind(-1e-3), new)
        assert count == np.count_nonzero(core)
        if count <= 20:
            assert moved == 0.0 and np.isnan(new).all()
            continue
        expect = np.minimum(np.median(diff[:, core != 0], axis=1), -1e-3)
        np.testing.assert_array_equal(new, expect)
        assert moved == float(np.abs(expect - d).max())


def test_relit_pixels_are_the_numpy_relighting():
    from simroad.filters._common import linear_to_camera
    from simroad.filters._relight_kernels import clip_inside, put_at, relit_linear
    from simroad.filters.relight import _linear_table

    rng = np.random.default_rng(21)
    table = _linear_table(1.0)
    for _k in range(10):
        alpha = rng.normal(0.3, 0.6, (27, 40)).astype(np.float32)
        alpha[0, :3] = [np.nan, -0.0, 1.0]
        region = (rng.random((27, 40)) < 0.6).astype(np.uint8)
        inside = np.empty_like(alpha)
        clip_inside(alpha, region, inside)
        np.testing.assert_array_equal(inside, np.where(region > 0, np.clip(alpha, 0.0, 1.0), 0.0).astype(np.float32))
        full = cv2.resize(np.nan_to_num(inside), (80, 54), interpolation=cv2.INTER_LINEAR)
        full[3, :3] = [np.float32(0.02), np.nextafter(np.float32(0.02), np.float32(1)), 0.9999]
        planes = [rng.random((54, 80), dtype=np.float32) for _ in range(3)]
        ks = rng.uniform(0.2, 0.6, 3).astype(np.float32)
        where, lin, mask = (
            np.empty(full.size, np.int64),
            np.empty((3, full.size), np.float32),
            np.empty(full.shape, bool),
        )
        n = relit_linear(full, np.float32(0.02), *planes, table, ks, where, lin, mask)
        sel = full > 0.02
        np.testing.assert_array_equal(mask, sel)
        assert n == sel.sum()
        np.testing.assert_array_equal(where[:n], np.flatnonzero(sel))
        expect = [p.copy() for p in planes]
        a = full[sel]
        for c, k in enumerate(ks):
            ref = _linearise_reference(planes[c][sel], table) / (1.0 - a * (1.0 - k))
            np.testing.assert_array_equal(lin[c, :n], ref)
            expect[c][sel] = linear_to_camera(ref, 1.0)
        put_at(where[:n], linear_to_camera(lin[:, :n], 1.0), *planes)  # cv2.pow: a function of the value alone
        np.testing.assert_array_equal(np.stack(planes), np.stack(expect))


def test_first_lit_is_the_dilation_test():
    from simroad.filters._relight_kernels import first_lit, first_lit_work

    rng = np.random.default_rng(22)
    for h, w, k in ((54, 160, 93), (54, 160, 9), (20, 31, 4), (7, 5, 30), (1, 12, 3), (33, 40, 1)):
        bright = (np.round(rng.normal(0.0, 1.0, (h, w)) * 4) / 4).astype(np.float32)  # ties
        lit_ok = (rng.random((h, w)) < 0.8).astype(np.float32)
        top = cv2.dilate(bright, np.ones((k, k), np.uint8))
        out = np.empty((h, w), np.float32)
        first_lit(bright, lit_ok, k, np.float32(0.8), out, np.empty(first_lit_work(h, w, k), np.float32))
        np.testing.assert_array_equal(out, lit_ok * (bright >= top - 0.8))


@pytest.mark.parametrize("kind", [np.float32, np.float64])
def test_the_mean_of_three_is_numpys(kind):
    """relight's ``d - (d[0] + d[1] + d[2]) / 3`` for ``d - d.mean()``: numpy sums three values left to right."""
    rng = np.random.default_rng(23)
    for d in (-rng.random((5000, 3)) * rng.uniform(1e-3, 3.0, (5000, 1))).astype(kind):
        assert (d[0] + d[1] + d[2]) / 3 == d.mean()


@pytest.mark.parametrize("power", [1 / 2.2, 2.2, 0.5, 3.0])
def test_pow_sparing_zeros_is_cv2_pow(power):
    from simroad.filters._common import pow_sparing_zeros

    rng = np.random.default_rng(17)
    x = rng.random((50, 256), dtype=np.float32)
    x[:, :60] = 0.0
    x[3, :5] = -0.0
    for a in (x, x[0], rng.random((4, 9), dtype=np.float32)):
        got, expect = pow_sparing_zeros(a, power), cv2.pow(a, power)
        assert got.shape == expect.shape
        np.testing.assert_array_equal(got, expect)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(expect))


def test_clip_planes_is_np_clip_bit_for_bit():
    from simroad.filters._common import clip_planes

    rng = np.random.default_rng(24)
    for shape in ((7,), (54, 160), (720, 1280)):
        x = (rng.random(shape, dtype=np.float32) * 1.4 - 0.2).reshape(-1)
        for step, value in ((13, -0.0), (17, np.nan), (19, 0.0), (23, 1.0), (29, -np.inf), (31, np.inf)):
            x[::step] = value
        x = x.reshape(shape)
        for plane, bits in ((x.copy(), np.uint32), (x.astype(np.float64), np.uint64)):  # compiled, numpy's
            expect = np.clip(plane, 0.0, 1.0)
            assert clip_planes([plane])[0] is plane
            np.testing.assert_array_equal(plane.view(bits), expect.view(bits))


def test_area_quarter_is_cv2_resize_area():
    from simroad.filters._common import gate_preview
    from simroad.filters._plane_kernels import area_quarter

    rng = np.random.default_rng(25)
    for h, w in ((720, 1280), (16, 16), (4, 8)):
        p = rng.random((h, w), dtype=np.float32)
        p.reshape(-1)[::7] = np.float32(1e-8)  # sums that are not exact in float32: the order shows
        p.reshape(-1)[::11] = -0.0
        out = np.empty((h // 4, w // 4), np.float32)
        area_quarter(p, out)
        expect = cv2.resize(p, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
        np.testing.assert_array_equal(out.view(np.uint32), expect.view(np.uint32))
    planes = [rng.random((720, 1280), dtype=np.float32) for _ in range(3)]
    for got, p in zip(gate_preview(planes), planes):  # the pipeline's preview of a 1280x720 frame
        np.testing.assert_array_equal(got, cv2.resize(p, (320, 180), interpolation=cv2.INTER_AREA))


@pytest.mark.parametrize("kind", ["uniform", "ties", "walk", "sorted", "reversed", "one"])
def test_isotonic_increasing_is_scipys_isotonic_regression(kind):
    from scipy.optimize import isotonic_regression  # the reference, not a dependency of the filters

    rng = np.random.default_rng(7)
    for _ in range(200):
        n = 1 if kind == "one" else int(rng.integers(2, 720))
        if kind == "uniform":
            y = rng.random(n)
        elif kind == "ties":
            y = np.round(rng.random(n) * 12) / 12
        elif kind == "walk":
            y = np.cumsum(rng.normal(size=n))
        elif kind in ("sorted", "reversed"):
            y = np.sort(rng.random(n))
            y = y[::-1].copy() if kind == "reversed" else y
        else:
            y = rng.random(1)
        fit = isotonic_increasing(y)
        assert np.array_equal(fit, isotonic_regression(y).x)
        assert np.all(np.diff(fit) >= 0)


def test_isotonic_increasing_by_hand():
    # [3, 1] pool to their mean 2; 2 joins them (not above 2); 5 stays; [4] after 5 pools to 4.5
    assert isotonic_increasing(np.array([3.0, 1.0, 2.0, 5.0, 4.0])).tolist() == [2.0, 2.0, 2.0, 4.5, 4.5]
