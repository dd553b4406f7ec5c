"""The realism report: its bookkeeping on hand-made values, the user's photographs as
a reference, and a few real rendered frames through to the files."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest

from simroad.errors import InvalidParameterError
from simroad.experiments.realism import (
    FRAME_COLUMNS,
    REALISM_SEEDS,
    RealismReport,
    format_realism_table,
    photo_reference,
    realism_figure,
    realism_report,
    write_realism,
)
from simroad.metrics.appearance import (
    MIN_ROAD_PIXELS,
    QUANTILE_LEVELS,
    STATISTICS,
    ks_distance,
    load_reference,
    reference_from_values,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _report() -> RealismReport:
    """Two scenarios of hand-made values: 'a' has road_V 0.1, 0.2, 0.3, 'b' 0.5, 0.6;
    every other statistic is the frame index; road_minus_surround is NaN in one frame."""
    frames = (("a", 1, 5), ("a", 1, 10), ("a", 2, 5), ("b", 1, 5), ("b", 1, 10))
    values = np.tile(np.arange(5.0)[:, None], (1, len(STATISTICS)))
    values[:, 0] = [0.1, 0.2, 0.3, 0.5, 0.6]
    values[2, STATISTICS.index("road_minus_surround")] = math.nan
    ref = reference_from_values({s: np.linspace(0.0, 1.0, 11) for s in STATISTICS}, "eleven values")
    return RealismReport(frames, values, ref, skipped=(("b", 2, 5),))


def test_report_samples_percentiles_and_ks():
    r = _report()
    assert r.scenarios == ("a", "b")
    assert r.sample("road_V").tolist() == [0.1, 0.2, 0.3, 0.5, 0.6]
    assert r.sample("road_V", "b").tolist() == [0.5, 0.6]
    assert r.sample("road_minus_surround", "a").tolist() == [0.0, 1.0]  # the NaN left out
    assert r.percentiles("road_V") == pytest.approx(np.quantile([0.1, 0.2, 0.3, 0.5, 0.6], [0.1, 0.5, 0.9]))
    table = r.reference.quantiles["road_V"]
    assert table == pytest.approx(np.linspace(0.0, 1.0, 21))
    assert r.ks("road_V") == ks_distance([0.1, 0.2, 0.3, 0.5, 0.6], table)
    # against the uniform on [0, 1], 0.5 and 0.6: ECDF 1/2 just below 0.6 is furthest from 0.6
    assert r.ks("road_V", "b") == pytest.approx(0.5)
    with pytest.raises(InvalidParameterError, match="statistic"):
        r.sample("road_L")
    with pytest.raises(InvalidParameterError, match="scenario"):
        r.sample("road_V", "c")


def test_report_rows_and_frame_rows():
    r = _report()
    rows = r.rows()
    assert [row["statistic"] for row in rows] == list(STATISTICS)
    assert list(rows[0]) == ["statistic", "ref_p10", "ref_p50", "ref_p90", "sim_p10", "sim_p50", "sim_p90",
                             "ks", "ks_a", "ks_b"]  # fmt: skip
    assert rows[0]["ref_p50"] == pytest.approx(0.5) and rows[0]["sim_p50"] == pytest.approx(0.3)
    assert rows[0]["ks_b"] == pytest.approx(0.5)
    frame_rows = r.frame_rows()
    assert len(frame_rows) == 5 and list(frame_rows[0]) == list(FRAME_COLUMNS)
    assert frame_rows[3]["scenario"] == "b" and frame_rows[3]["road_V"] == 0.5


def test_an_empty_report_has_nan_not_errors():
    r = RealismReport((), np.zeros((0, len(STATISTICS))), load_reference(), skipped=(("a", 1, 5),))
    assert r.scenarios == () and r.sample("road_V").size == 0
    assert math.isnan(r.ks("road_V")) and np.isnan(r.percentiles("road_V")).all()
    assert "0 frames" in format_realism_table(r) and "1 left out" in format_realism_table(r)


def test_table_lists_every_statistic_and_the_reference():
    text = format_realism_table(_report())
    lines = text.splitlines()
    assert lines[0].split()[:4] == ["statistic", "ref", "p10", "ref"] and lines[0].endswith("KS b")
    for s in STATISTICS:
        assert any(line.startswith(s + " ") for line in lines)
    assert "5 frames (a 3, b 2); 1 left out" in text and "reference: eleven values" in text


def test_files_of_a_report(tmp_path):
    paths = write_realism(_report(), tmp_path / "out")
    assert sorted(p.name for p in paths.values()) == ["realism.csv", "realism.json", "realism.png"]
    with paths["csv"].open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 5 and tuple(rows[0]) == FRAME_COLUMNS
    assert rows[2]["road_minus_surround"] == "nan" and float(rows[4]["road_V"]) == 0.6
    summary = json.loads(paths["json"].read_text())
    assert summary["frames"] == 5 and summary["skipped"] == [["b", 2, 5]] and summary["reference"] == "eleven values"
    assert [s["statistic"] for s in summary["statistics"]] == list(STATISTICS)
    assert paths["figure"].read_bytes()[:8] == PNG_MAGIC and imageio.imread(paths["figure"]).ndim == 3


def test_figure_path_is_checked_before_drawing(tmp_path):
    with pytest.raises(InvalidParameterError, match="path"):
        realism_figure(_report(), tmp_path / "figure.unknown")


# ---- the user's photographs ----------------------------------------------------------


def _photo(k: int, road_rows: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """An 80 x 60 'photograph' (RGB): sky, verge, and a grey road in the bottom rows."""
    rgb = np.empty((60, 80, 3), np.uint8)
    rgb[:30] = (170, 190, 220)
    rgb[30:] = (70, 110, 50)
    mask = np.zeros((60, 80), np.uint8)
    mask[60 - road_rows :, 10:70] = 255
    rgb[mask > 0] = (90 + 10 * k,) * 3
    return rgb, mask


def _write_photos(root: Path, shots: list[tuple[np.ndarray, np.ndarray]]) -> tuple[Path, Path]:
    photos, masks = root / "photos", root / "masks"
    photos.mkdir()
    masks.mkdir()
    for k, (rgb, mask) in enumerate(shots):
        cv2.imwrite(str(photos / f"p{k}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(masks / f"p{k}.png"), mask)
    return photos, masks


def test_photo_reference_from_a_folder(tmp_path):
    photos, masks = _write_photos(tmp_path, [_photo(0), _photo(1), _photo(2), _photo(3, road_rows=2)])
    ref = photo_reference(photos, masks)  # the last photo has 2 x 60 = 120 road pixels: left out
    assert ref.source == f"3 photographs in {photos} (1 left out: fewer than {MIN_ROAD_PIXELS} road pixels)"
    assert ref.quantiles["road_V"] == pytest.approx(np.quantile([90 / 255, 100 / 255, 110 / 255], QUANTILE_LEVELS))
    assert ref.quantiles["road_S"] == pytest.approx(np.zeros(21))
    assert ref.quantiles["road_minus_surround"][10] == pytest.approx((100 - 110) / 255)  # verge V = 110


def test_photo_reference_refusals(tmp_path):
    (tmp_path / "x").mkdir()
    photos, masks = _write_photos(tmp_path / "x", [_photo(0), _photo(1)])
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InvalidParameterError, match=r"photos: no image in .*empty"):
        photo_reference(empty, masks)
    with pytest.raises(InvalidParameterError, match=r"masks: .*not a directory"):
        photo_reference(photos, tmp_path / "nowhere")
    cv2.imwrite(str(masks / "p1.png"), np.zeros((30, 40), np.uint8))
    with pytest.raises(InvalidParameterError, match=r"masks: p1\.png is \(40, 30\) but p1\.png is \(80, 60\)"):
        photo_reference(photos, masks)
    for name in ("p0.png", "p1.png"):
        cv2.imwrite(str(masks / name), np.zeros((60, 80), np.uint8))
    with pytest.raises(InvalidParameterError, match=r"masks: .*/p0\.png marks no road pixel"):
        photo_reference(photos, masks)
    for name in ("p0.png", "p1.png"):
        few = np.zeros((60, 80), np.uint8)
        few[50:55, 10:30] = 255  # 100 road pixels
        cv2.imwrite(str(masks / name), few)
    with pytest.raises(InvalidParameterError, match=r"masks: none of the 2 masks in .*masks.* 500 or more"):
        photo_reference(photos, masks)
    for name in ("p0.png", "p1.png"):
        cv2.imwrite(str(masks / name), np.full((60, 80), 255, np.uint8))  # the road fills the lower half
    with pytest.raises(InvalidParameterError, match="road fills the lower half"):
        photo_reference(photos, masks)


# ---- real rendered frames --------------------------------------------------------------


def test_default_worlds_are_the_held_out_5000s():
    assert (REALISM_SEEDS[0], REALISM_SEEDS[-1], len(REALISM_SEEDS)) == (5000, 5012, 13)


def test_a_real_report_on_two_highway_frames(tmp_path):
    r = realism_report(scenarios=("highway",), seeds=(5000,), frames=2)
    assert r.frames == (("highway", 5000, 5), ("highway", 5000, 10)) and r.skipped == ()
    assert r.values.shape == (2, len(STATISTICS)) and r.reference.source.startswith("Per-frame")
    for s in ("road_V", "road_S", "road_spread", "frame_V", "saturated"):
        assert np.all((r.sample(s) >= 0.0) & (r.sample(s) <= 1.0)), s
    assert all(0.0 <= row["ks"] <= 1.0 for row in r.rows())
    paths = write_realism(r, tmp_path)
    assert len(paths["csv"].read_text().splitlines()) == 3
    # the same worlds give the same numbers; env_options reach the env
    small = realism_report(scenarios=("highway",), seeds=(5000,), frames=1, env_options={"width": 160, "height": 90})
    assert small.frames == (("highway", 5000, 5),) and not np.allclose(small.values[0], r.values[0])


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"frames": 0}, "frames"),
        ({"every": 0}, "every"),
        ({"seeds": []}, "seeds"),
        ({"seeds": [-1]}, "seeds"),
        ({"scenarios": ("higway",)}, "scenarios"),
        ({"env_options": {"noise": "rain"}}, "env_options: noise"),
        ({"env_options": [("width", 10)]}, "env_options"),
        ({"env_options": {"widht": 160}}, "widht"),
        ({"reference": 3}, "reference"),
        ({"reference": "/nowhere/ref.csv"}, "reference"),
    ],
)
def test_report_refuses_bad_arguments_before_rendering(kw, name):
    with pytest.raises(InvalidParameterError, match=name):
        realism_report(**{"scenarios": ("highway",), "seeds": (5000,), **kw})
