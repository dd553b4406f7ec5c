"""Appearance statistics: each one on frames worked out by hand, the exact KS distance
against scipy and hand cases, and the quantile-table files (shipped and malformed)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import ks_2samp

from simroad.errors import InvalidParameterError
from simroad.metrics.appearance import (
    MIN_ROAD_PIXELS,
    QUANTILE_LEVELS,
    STATISTICS,
    AppearanceReference,
    frame_appearance,
    ks_distance,
    load_reference,
    reference_from_values,
)

ROAD, SURROUND, SKY = (100, 100, 100), (60, 60, 60), (180, 200, 230)


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """40 x 60: sky in the upper half (with 9 bright pixels, 7 of them clipped), a grey
    road of 20 x 30 = 600 pixels in the lower half, 600 darker grey pixels beside it."""
    rgb = np.empty((40, 60, 3), np.uint8)
    rgb[:20] = SKY
    rgb[20:] = SURROUND
    road = np.zeros((40, 60), bool)
    road[20:, 15:45] = True
    rgb[road] = ROAD
    rgb[0, :6] = 255  # clipped
    rgb[1, 0] = (250, 251, 252)  # clipped: every channel >= 250
    rgb[1, 1] = (255, 255, 249)  # not clipped: one channel below 250
    rgb[1, 2] = (249, 255, 255)  # not clipped
    return rgb, road


def test_statistics_of_a_uniform_grey_road():
    rgb, road = _scene()
    s = frame_appearance(rgb, road)
    assert s is not None and list(s) == list(STATISTICS)
    assert s["road_V"] == pytest.approx(100 / 255)
    assert s["road_S"] == 0.0  # grey: max == min
    assert s["road_b"] == 0.0 and s["road_a"] == 0.0  # grey: a = b = 128 in 8-bit Lab
    assert s["road_minus_surround"] == pytest.approx((100 - 60) / 255)
    assert s["road_spread"] == 0.0
    # V = max(R, G, B): 600 road pixels at 100, 600 surround at 60, 1191 sky at 230,
    # 8 at 255 (six white, two with one channel at 249) and one at 252
    v_sum = 600 * 100 + 600 * 60 + 1191 * 230 + 8 * 255 + 252
    assert s["frame_V"] == pytest.approx(v_sum / 2400 / 255)
    assert s["saturated"] == pytest.approx(7 / 2400)


def test_saturation_of_a_coloured_road():
    rgb, road = _scene()
    rgb[road] = (120, 105, 90)  # S = (max - min) / max = 30 / 120
    s = frame_appearance(rgb, road)
    assert s is not None
    assert s["road_S"] == pytest.approx(round(255 * 30 / 120) / 255)  # OpenCV rounds S to 8 bits
    assert s["road_V"] == pytest.approx(120 / 255)


def test_spread_median_and_nan_surround_on_a_v_ramp():
    # the road fills the lower half: 10 rows whose grey level is the column, 0..255
    rgb = np.zeros((20, 256, 3), np.uint8)
    rgb[10:] = np.arange(256, dtype=np.uint8)[None, :, None]
    road = np.zeros((20, 256), bool)
    road[10:] = True
    s = frame_appearance(rgb, road)
    assert s is not None
    # 2560 sorted values, value i // 10 at index i; numpy's linear percentile at
    # p * 2559: p10 -> index 255.9 (25 and 25), p90 -> 2303.1 (230 and 230), p50 -> 1279.5 (127, 128)
    assert s["road_spread"] == pytest.approx((230 - 25) / 255)
    assert s["road_V"] == pytest.approx(127.5 / 255)
    assert math.isnan(s["road_minus_surround"])  # no non-road pixel in the lower half
    assert s["frame_V"] == pytest.approx(10 * sum(range(256)) / 5120 / 255)
    assert s["saturated"] == pytest.approx(6 * 10 / 5120)  # columns 250..255


def _lab_by_hand(rgb: tuple[int, int, int]) -> tuple[float, float]:
    """a*, b* of an sRGB colour by the CIE formulas (D65 white), independent of OpenCV."""
    c = np.asarray(rgb, float) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    m = np.array(
        [[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]]
    )
    x, y, z = m @ lin / np.array([0.950456, 1.0, 1.088754])

    def f(t: float) -> float:
        return t ** (1 / 3) if t > (6 / 29) ** 3 else t / (3 * (6 / 29) ** 2) + 4 / 29

    return 500 * (f(x) - f(y)), 200 * (f(y) - f(z))


@pytest.mark.parametrize(
    ("colour", "b_sign", "a_sign"),
    [
        ((90, 100, 140), -1, 0),  # bluish asphalt: b* < 0
        ((150, 135, 80), +1, 0),  # yellowish (dusty) road: b* > 0
        ((150, 100, 100), 0, +1),  # reddish: a* > 0
        ((90, 130, 90), 0, -1),  # greenish: a* < 0
    ],
)
def test_colour_opponents_match_the_cie_formula(colour, b_sign, a_sign):
    rgb, road = _scene()
    rgb[road] = colour
    s = frame_appearance(rgb, road)
    assert s is not None
    a_ref, b_ref = _lab_by_hand(colour)
    assert s["road_a"] == pytest.approx(a_ref, abs=1.0)  # 8-bit Lab rounds a* and b* to integers
    assert s["road_b"] == pytest.approx(b_ref, abs=1.0)
    if b_sign:
        assert np.sign(s["road_b"]) == b_sign and abs(b_ref) > 5
    if a_sign:
        assert np.sign(s["road_a"]) == a_sign and abs(a_ref) > 5


def test_too_few_road_pixels_give_no_statistics():
    rgb, _ = _scene()
    road = np.zeros((40, 60), bool)
    road.flat[: MIN_ROAD_PIXELS - 1] = True
    assert frame_appearance(rgb, road) is None
    assert frame_appearance(rgb, road, min_road_pixels=MIN_ROAD_PIXELS - 1) is not None
    assert frame_appearance(rgb, np.zeros((40, 60), bool)) is None


def test_a_0_1_integer_mask_is_accepted():
    rgb, road = _scene()
    assert frame_appearance(rgb, road.astype(np.uint8)) == frame_appearance(rgb, road)


@pytest.mark.parametrize(
    ("rgb", "mask", "kw", "name"),
    [
        (np.zeros((40, 60, 3), np.float32), np.ones((40, 60), bool), {}, "rgb"),
        (np.zeros((40, 60), np.uint8), np.ones((40, 60), bool), {}, "rgb"),
        (np.zeros((40, 60, 4), np.uint8), np.ones((40, 60), bool), {}, "rgb"),
        (np.zeros((40, 60, 3), np.uint8), np.ones((60, 40), bool), {}, "road_mask"),
        (np.zeros((40, 60, 3), np.uint8), np.full((40, 60), 255, np.uint8), {}, "road_mask"),
        (np.zeros((40, 60, 3), np.uint8), np.ones((40, 60), bool), {"min_road_pixels": 0}, "min_road_pixels"),
    ],
    ids=["float-frame", "grey-frame", "rgba-frame", "mask-shape", "mask-0-255", "min-pixels"],
)
def test_bad_inputs_are_refused_by_name(rgb, mask, kw, name):
    with pytest.raises(InvalidParameterError, match=name):
        frame_appearance(rgb, mask, **kw)


# ---- ks_distance ---------------------------------------------------------------


@pytest.mark.parametrize("draw", ["normal", "beta"])
@pytest.mark.parametrize("shift", [0.0, 0.1, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ks_distance_agrees_with_scipy_on_continuous_data(draw, shift, seed):
    rng = np.random.default_rng(seed)

    def sample(n: int) -> np.ndarray:
        return rng.normal(0.0, 1.0, n) if draw == "normal" else rng.beta(2.0, 3.0, n)

    reference = sample(100_000)
    table = np.quantile(reference, QUANTILE_LEVELS)
    values = sample(200) + shift * reference.std()
    expected = ks_2samp(values, reference).statistic
    assert ks_distance(values, table) == pytest.approx(expected, abs=0.01)


def test_ks_distance_of_the_knots_themselves_is_one_over_21():
    # the sample's ECDF steps by 1/21 at each knot, the table rises 1/20 per knot:
    # largest gap (20 - k) / 420 at knot k = 0 (and k / 420 from the left at k = 20)
    q = np.linspace(0.0, 2.0, 21) ** 2
    assert ks_distance(q, q) == pytest.approx(1 / 21)


def test_ks_distance_of_disjoint_samples_is_one():
    q = np.linspace(1.0, 2.0, 21)
    assert ks_distance([0.0, 0.5, 0.999], q) == 1.0
    assert ks_distance([2.5, 3.0], q) == 1.0
    assert ks_distance([1.0], np.full(21, 1.0)) == 0.0  # a point mass against the same point


def test_ks_distance_across_the_jumps_of_tied_quantiles():
    # q00..q45 = 0, q50..q100 = 1: the CDF jumps to 0.45 at 0, rises linearly to 0.5
    # just below 1, and jumps to 1 at 1
    q = np.array([0.0] * 10 + [1.0] * 11)
    assert ks_distance([1.0] * 4, q) == pytest.approx(0.5)  # the left limit at 1: 0 vs 0.5
    assert ks_distance([0.5] * 4, q) == pytest.approx(0.525)  # at 0.5: 1 vs 0.475
    assert ks_distance([0.0] * 9 + [1.0] * 11, q) == pytest.approx(0.05)  # 0.45 vs 0.5 below 1
    assert ks_distance([0.0], q) == pytest.approx(0.55)


def test_ks_distance_leaves_nan_out():
    q = np.linspace(0.0, 1.0, 21)
    assert ks_distance([0.2, math.nan, 0.7], q) == ks_distance([0.2, 0.7], q)


@pytest.mark.parametrize(
    ("values", "quantiles", "name"),
    [
        ([0.5], np.linspace(0, 1, 20), "quantiles"),
        ([0.5], np.linspace(1, 0, 21), "quantiles"),
        ([0.5], np.r_[np.linspace(0, 1, 20), np.nan], "quantiles"),
        ([0.5], np.linspace(0, 1, 21).reshape(3, 7), "quantiles"),
        ([], np.linspace(0, 1, 21), "values"),
        ([math.nan], np.linspace(0, 1, 21), "values"),
        (["road"], np.linspace(0, 1, 21), "values"),
        (np.array([[0.9, 0.1], [0.5, 0.3]]), np.linspace(0, 1, 21), "values"),  # was sorted row by row
        ([0.5], ["low"] * 21, "quantiles"),
    ],
    ids=["short", "decreasing", "nan", "2-d", "empty", "all-nan", "text", "2-d-values", "text-quantiles"],
)
def test_ks_distance_refuses_bad_input_by_name(values, quantiles, name):
    with pytest.raises(InvalidParameterError, match=name):
        ks_distance(values, quantiles)


# ---- references ------------------------------------------------------------------


def test_the_shipped_reference():
    ref = load_reference()
    assert isinstance(ref, AppearanceReference) and list(ref.quantiles) == list(STATISTICS)
    assert all(q.shape == (21,) and np.all(np.diff(q) >= 0) for q in ref.quantiles.values())
    assert "CamVid" in ref.source
    # the numbers: p10 / median / p90
    assert ref.percentiles("road_V") == pytest.approx([0.12, 0.30, 0.42], abs=0.005)
    assert ref.percentiles("road_b") == pytest.approx([-6.0, -3.0, 0.0])
    assert ref.percentiles("road_V", [0.0, 1.0]) == pytest.approx([0.0784, 0.6039])
    assert ref.percentiles("road_V", [0.125]) == pytest.approx((0.1216 + 0.1333) / 2)  # between two knots
    with pytest.raises(InvalidParameterError, match="statistic"):
        ref.percentiles("road_L")


def _table_text(rows: dict[str, list[float]], header: str | None = None) -> str:
    head = header or "statistic," + ",".join(f"q{round(q * 100):02d}" for q in QUANTILE_LEVELS)
    lines = ["# a test table", head] + [f"{k}," + ",".join(f"{v:g}" for v in vals) for k, vals in rows.items()]
    return "\n".join(lines) + "\n"


def _rows() -> dict[str, list[float]]:
    return {s: list(np.linspace(0.0, 1.0, 21) + i) for i, s in enumerate(STATISTICS)}


def test_load_reference_reads_a_written_table(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text(_table_text(_rows()))
    ref = load_reference(path)
    assert ref.source == "a test table"
    assert ref.quantiles["road_S"] == pytest.approx(np.linspace(1.0, 2.0, 21))


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda r: _table_text(r, header="statistic,p10,p50,p90"), "header"),
        (lambda r: _table_text({k: v for k, v in r.items() if k != "road_b"}), "road_b"),
        (lambda r: _table_text({**r, "road_V": r["road_V"][::-1]}), r"road_V.*non-decreasing"),
        (lambda r: _table_text({**r, "road_V": r["road_V"][:20]}), r"road_V.*21"),
        (lambda r: _table_text(r).replace("saturated,7", "saturated,x"), "saturated"),  # its row starts at 7
        (lambda r: "", "header"),
    ],
    ids=["bad-header", "missing-statistic", "decreasing-row", "short-row", "non-number", "empty"],
)
def test_load_reference_refuses_malformed_files_by_name(tmp_path, edit, match):
    path = tmp_path / "bad.csv"
    path.write_text(edit(_rows()))
    with pytest.raises(InvalidParameterError, match=match) as err:
        load_reference(path)
    assert str(err.value).startswith("reference:") and ("bad.csv" in str(err.value))


def test_load_reference_refuses_a_missing_file(tmp_path):
    with pytest.raises(InvalidParameterError, match=r"reference.*not a file"):
        load_reference(tmp_path / "nowhere.csv")
    with pytest.raises(InvalidParameterError, match=r"reference.*not a file"):
        load_reference(tmp_path)


def test_reference_from_values():
    rng = np.random.default_rng(3)
    values = {s: rng.normal(i, 1.0, 50) for i, s in enumerate(STATISTICS)}
    values["road_minus_surround"] = np.r_[values["road_minus_surround"], [math.nan] * 5]
    ref = reference_from_values(values, "my photos")
    assert ref.source == "my photos" and list(ref.quantiles) == list(STATISTICS)
    for s in STATISTICS:
        v = np.asarray(values[s])
        v = v[np.isfinite(v)]
        assert ref.quantiles[s] == pytest.approx(np.quantile(v, QUANTILE_LEVELS))
        assert ref.quantiles[s][0] == v.min() and ref.quantiles[s][-1] == v.max()
        assert ks_distance(v, ref.quantiles[s]) < 0.05  # the values against their own table


def test_reference_from_values_needs_every_statistic():
    values = {s: [0.1, 0.2] for s in STATISTICS}
    with pytest.raises(InvalidParameterError, match="road_minus_surround"):
        reference_from_values({**values, "road_minus_surround": [math.nan]}, "x")
    with pytest.raises(InvalidParameterError, match="saturated"):
        reference_from_values({k: v for k, v in values.items() if k != "saturated"}, "x")
