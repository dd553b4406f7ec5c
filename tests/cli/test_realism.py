"""``simroad realism``: its options refused by name before any frame is rendered, the
user's photographs as the reference, and the files of a small real run."""

from __future__ import annotations

import csv
import functools
from importlib import resources
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest

from simroad.cli.main import main
from simroad.cli.parser import build_parser
from simroad.experiments import realism as realism_module
from simroad.experiments.realism import FRAME_COLUMNS, REALISM_SEEDS
from simroad.metrics.appearance import STATISTICS

SMALL = ["--scenarios", "highway", "--seeds", "1", "--seed-start", "5000", "--frames", "1", "--quiet"]


def test_defaults_are_the_librarys():
    args = build_parser().parse_args(["realism"])
    assert range(args.seed_start, args.seed_start + args.seeds) == REALISM_SEEDS
    assert args.frames == 4 and args.every == 5
    assert args.scenarios == ("racetrack", "highway", "winding", "town") and args.out == "runs/realism"
    assert (args.photos, args.masks, args.reference) == (None, None, None)


def test_seeds_and_seed_start_name_consecutive_worlds(monkeypatch, tmp_path):
    seen = {}

    @functools.wraps(realism_module.realism_report)  # the parser reads its defaults
    def fake_report(**kw):
        seen.update(kw)
        raise SystemExit(0)

    monkeypatch.setattr("simroad.cli.realism.realism_report", fake_report)
    with pytest.raises(SystemExit):
        main(["realism", "--seeds", "3", "--seed-start", "7000", "--quiet", "--out", str(tmp_path)])
    assert tuple(seen["seeds"]) == (7000, 7001, 7002)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--seeds", "0"], "--seeds"),
        (["--seeds", "5000-5002"], "--seeds"),
        (["--seed-start", "-1"], "--seed-start"),
        (["--seeds", "2", "--seed-start", "2147483647"], "largest seed"),
        (["--frames", "0"], "--frames"),
        (["--scenarios", "higway"], "Did you mean 'highway'"),
        (["--photos", "{tmp}/nowhere", "--masks", "{tmp}"], "--photos"),
        (["--reference", "{tmp}/nowhere.csv"], "--reference"),
    ],
)
def test_bad_options_are_refused_by_name(argv, words, tmp_path, capsys):
    assert main(["realism", *[a.replace("{tmp}", str(tmp_path)) for a in argv]]) == 2
    assert words in capsys.readouterr().err


def _no_rendering(monkeypatch):
    def fail(**kwargs):
        raise AssertionError("rendered frames before refusing the options")

    monkeypatch.setattr(realism_module, "collect_frames", fail)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--photos", "{tmp}"], "--photos/--masks: give both folders"),
        (["--masks", "{tmp}"], "--photos/--masks: give both folders"),
        (["--photos", "{tmp}", "--masks", "{tmp}", "--reference", "{tmp}/ref.csv"], "--reference: a reference comes"),
        (["--reference", "{tmp}/ref.csv"], "must start with the header"),
    ],
)
def test_reference_options_are_refused_before_rendering(argv, words, tmp_path, capsys, monkeypatch):
    _no_rendering(monkeypatch)
    (tmp_path / "ref.csv").write_text("statistic,p10,p50,p90\n")
    assert main(["realism", *[a.replace("{tmp}", str(tmp_path)) for a in argv], "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("simroad realism: error: ") and words in err
    assert not (tmp_path / "o").exists()


def _photos(root: Path, mask_of) -> tuple[Path, Path]:
    """Three synthetic 96 x 64 road photos (sky, verge, grey road) and masks from
    ``mask_of(k, road)``, ``road`` the true 0/255 mask of photo ``k``."""
    photos, masks = root / "photos", root / "masks"
    photos.mkdir()
    masks.mkdir()
    for k in range(3):
        rgb = np.empty((64, 96, 3), np.uint8)
        rgb[:32] = (175, 195, 225)
        rgb[32:] = (80, 120, 60)
        road = np.zeros((64, 96), np.uint8)
        road[40:, 20:76] = 255
        rgb[road > 0] = (95 + 5 * k, 97 + 5 * k, 104 + 5 * k)
        cv2.imwrite(str(photos / f"shot{k}.jpg"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        mask = mask_of(k, road)
        if mask is not None:
            cv2.imwrite(str(masks / f"shot{k}.png"), mask)
    return photos, masks


@pytest.mark.parametrize(
    ("mask_of", "words"),
    [
        (lambda k, road: None, "no mask in"),
        (lambda k, road: road[:32] if k == 1 else road, "shot1.png is (96, 32) but shot1.jpg is (96, 64)"),
        (lambda k, road: road * 0, "shot0.png marks no road pixel"),
    ],
    ids=["no-masks", "wrong-size", "no-road"],
)
def test_unusable_photos_are_refused(mask_of, words, tmp_path, capsys, monkeypatch):
    _no_rendering(monkeypatch)
    photos, masks = _photos(tmp_path, mask_of)
    assert main(["realism", "--photos", str(photos), "--masks", str(masks), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert words in err and (str(photos) in err or str(masks) in err or "shot1" in err)


def test_own_photos_as_the_reference_and_the_files(tmp_path, capsys):
    photos, masks = _photos(tmp_path, lambda k, road: road)
    out = tmp_path / "out"
    assert main(["realism", "--photos", str(photos), "--masks", str(masks), "--out", str(out), *SMALL]) == 0
    printed = capsys.readouterr().out
    assert f"reference: 3 photographs in {photos}" in printed
    for s in STATISTICS:
        assert f"\n{s} " in printed
    with (out / "realism.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 1 and tuple(rows[0]) == FRAME_COLUMNS
    assert (rows[0]["scenario"], rows[0]["seed"], rows[0]["step"]) == ("highway", "5000", "5")
    png = out / "realism.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and imageio.imread(png).shape[2] in (3, 4)
    assert (out / "realism.json").is_file()


@pytest.mark.slow  # four scenarios' worlds
def test_the_shipped_reference_and_a_table_file(tmp_path, capsys):
    shipped = resources.files("simroad.data") / "road_photos_appearance.csv"
    out = tmp_path / "out"
    argv = ["realism", "--seeds", "1", "--seed-start", "5000", "--frames", "1", "--quiet", "--out", str(out)]
    assert main(argv) == 0
    first = capsys.readouterr().out
    assert main([*argv, "--reference", str(shipped)]) == 0  # the same table through --reference
    assert capsys.readouterr().out.splitlines()[:9] == first.splitlines()[:9]
    with (out / "realism.csv").open() as fh:
        assert [r["scenario"] for r in csv.DictReader(fh)] == ["racetrack", "highway", "winding", "town"]
