"""Photographs and their road masks in the formats datasets use: the same road from
each, and every mask that cannot be read as a road refused by name."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from simroad.cli.main import main
from simroad.errors import InvalidParameterError
from simroad.experiments.evaluate import evaluate_detector
from simroad.experiments.photos import check_road_colour, load_image_folder, read_road_mask

H, W = 60, 80
KITTI_ROAD, KITTI_OTHER = (255, 0, 255), (255, 0, 0)


def _scene(k: int) -> tuple[np.ndarray, np.ndarray]:
    """A photo (RGB) with a grey road trapezoid on green and a grey sky, and its road."""
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[: H // 3] = (150, 160, 175)
    rgb[H // 3 :] = (60, 110 + 5 * k, 50)
    road = np.zeros((H, W), np.uint8)
    poly = np.array([[35 - k, H // 3], [45 + k, H // 3], [W - 5, H - 1], [5, H - 1]], np.int32)
    cv2.fillPoly(road, [poly], 1)
    rgb[road == 1] = (90 + 3 * k, 92, 95)
    return rgb, road.astype(bool)


def _labels(road: np.ndarray) -> np.ndarray:
    """A Cityscapes-like label image: road 7, sky 23, vegetation 21, a car 26."""
    lab = np.full((H, W), 21, np.uint8)
    lab[: H // 3] = 23
    lab[road] = 7
    lab[H - 12 : H - 4, 30:42] = np.where(road[H - 12 : H - 4, 30:42], 26, 21)
    return lab


def _write(root, fmt: str, n: int = 3):
    """Photos and masks in format ``fmt``; returns (images dir, masks dir, roads)."""
    images, masks = root / "images", root / f"masks-{fmt}"
    images.mkdir(exist_ok=True)
    masks.mkdir()
    roads = []
    for k in range(n):
        rgb, road = _scene(k)
        if fmt == "labels":
            road = _labels(road) == 7  # the car covers some road
        roads.append(road)
        cv2.imwrite(str(images / f"p{k}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        if fmt == "0-255":
            mask = road.astype(np.uint8) * 255
        elif fmt == "0-1":
            mask = road.astype(np.uint8)
        elif fmt == "labels":
            mask = _labels(_scene(k)[1])
        else:  # KITTI's colours, written as BGR
            mask = np.where(road[..., None], KITTI_ROAD[::-1], KITTI_OTHER[::-1]).astype(np.uint8)
        cv2.imwrite(str(masks / f"p{k}.png"), mask)
    return images, masks, roads


OPTIONS = {"0-255": {}, "0-1": {}, "labels": {"road_value": 7}, "colour": {"road_colour": KITTI_ROAD}}


@pytest.mark.parametrize("fmt", list(OPTIONS))
def test_each_format_reads_the_road_it_marks(tmp_path, fmt):
    images, masks, roads = _write(tmp_path, fmt)
    frames = load_image_folder(images, masks, **OPTIONS[fmt])
    assert len(frames.masks) == 3
    for got, want in zip(frames.masks, roads):
        np.testing.assert_array_equal(got, want)


def test_the_same_photos_in_four_formats_give_the_same_numbers(tmp_path, capsys):
    """0/255, 0/1 and a colour mask marking one road give the same scores, from the
    library and from the command line; a label image its own road (a car hides some)."""
    rows, flags = (
        {},
        {"0-255": [], "0-1": [], "labels": ["--road-value", "7"], "colour": ["--road-colour", "255,0,255"]},
    )
    for fmt, options in OPTIONS.items():
        (tmp_path / fmt).mkdir()
        images, masks, _ = _write(tmp_path / fmt, fmt)
        rows[fmt], _ = evaluate_detector(["none"], images=images, masks=masks, **options)
        capsys.readouterr()
        argv = ["evaluate-detector", "--images", str(images), "--masks", str(masks), "--filters", "none", "--json"]
        assert main([*argv, *flags[fmt]]) == 0
        assert json.loads(capsys.readouterr().out)["rows"] == rows[fmt], fmt
    assert rows["0-255"] == rows["0-1"] == rows["colour"]
    assert rows["0-255"][0]["frames"] == 3 and 0.0 < rows["0-255"][0]["iou"] <= 1.0
    assert rows["labels"][0]["frames"] == 3 and rows["labels"] != rows["0-255"]


def test_the_command_line_prints_the_librarys_rows(tmp_path, capsys):
    images, masks, _ = _write(tmp_path, "colour")
    want, _ = evaluate_detector(["none"], images=images, masks=masks, road_colour="#FF00FF")
    capsys.readouterr()
    argv = ["evaluate-detector", "--images", str(images), "--masks", str(masks), "--filters", "none", "--json"]
    assert main([*argv, "--road-colour", "255,0,255"]) == 0
    assert json.loads(capsys.readouterr().out)["rows"] == want


def test_grey_edges_jpeg_and_16_bit_masks_read_as_black_and_white(tmp_path):
    _, road = _scene(0)
    soft = cv2.GaussianBlur(road.astype(np.uint8) * 255, (5, 5), 1.0)  # anti-aliased edges
    cv2.imwrite(str(tmp_path / "soft.png"), soft)
    cv2.imwrite(str(tmp_path / "jpeg.jpg"), road.astype(np.uint8) * 255, [cv2.IMWRITE_JPEG_QUALITY, 75])
    cv2.imwrite(str(tmp_path / "wide.png"), road.astype(np.uint16) * 65535)
    cv2.imwrite(str(tmp_path / "rgb.png"), np.repeat(road[..., None].astype(np.uint8) * 255, 3, axis=-1))
    for name, agree in (("soft.png", 0.97), ("jpeg.jpg", 0.99), ("wide.png", 1.0), ("rgb.png", 1.0)):
        got = read_road_mask(tmp_path / name)
        assert (got == road).mean() >= agree, name


def test_masks_that_are_not_a_road_are_refused_by_name(tmp_path):
    _, road = _scene(0)
    cv2.imwrite(str(tmp_path / "empty.png"), np.zeros((H, W), np.uint8))
    with pytest.raises(InvalidParameterError, match=r"empty\.png marks no road pixel .*--road-value"):
        read_road_mask(tmp_path / "empty.png")
    kitti = np.where(road[..., None], KITTI_ROAD[::-1], KITTI_OTHER[::-1]).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "kitti.png"), kitti)
    with pytest.raises(InvalidParameterError, match=r"kitti\.png is a colour image \(\(255, 0, \d+\) .*--road-colour"):
        read_road_mask(tmp_path / "kitti.png")
    with pytest.raises(InvalidParameterError, match=r"kitti\.png marks no road pixel \(no pixel has the colour"):
        read_road_mask(tmp_path / "kitti.png", road_colour=(0, 255, 0))
    cv2.imwrite(str(tmp_path / "labels.png"), _labels(road))
    with pytest.raises(
        InvalidParameterError, match=r"labels\.png looks like a label image \(values 7, 21, 23.*--road-value"
    ):
        read_road_mask(tmp_path / "labels.png")
    with pytest.raises(InvalidParameterError, match=r"labels\.png marks no road pixel \(no pixel has the value 8\)"):
        read_road_mask(tmp_path / "labels.png", road_value=8)
    with pytest.raises(InvalidParameterError, match=r"road_value: .* not both"):
        read_road_mask(tmp_path / "labels.png", road_value=7, road_colour=(1, 2, 3))
    with pytest.raises(InvalidParameterError, match="road_value: expected an integer"):
        read_road_mask(tmp_path / "labels.png", road_value=300)
    (tmp_path / "text.png").write_text("not an image")
    with pytest.raises(InvalidParameterError, match=r"could not read .*text\.png"):
        read_road_mask(tmp_path / "text.png")


def test_an_image_without_a_mask_is_named_and_masks_without_images_are_ignored(tmp_path):
    images, masks, _ = _write(tmp_path, "0-255", n=4)
    (masks / "p3.png").unlink()
    with pytest.raises(InvalidParameterError, match=r"masks: no mask in .* for p3\.png"):
        load_image_folder(images, masks)
    (images / "p3.png").unlink()
    cv2.imwrite(str(masks / "extra.png"), np.full((H, W), 255, np.uint8))
    assert len(load_image_folder(images, masks).images) == 3


def test_a_label_or_colour_option_without_photos_is_refused(tmp_path, capsys):
    assert main(["evaluate-detector", "--road-value", "7"]) == 2
    assert "--road-value" in capsys.readouterr().err
    with pytest.raises(InvalidParameterError, match="road_value"):
        evaluate_detector(["none"], road_colour=(1, 2, 3))


@pytest.mark.parametrize(
    ("given", "want"),
    [
        ("255,0,255", (255, 0, 255)),
        (" 1, 2 ,3 ", (1, 2, 3)),
        ("#ff00FF", (255, 0, 255)),
        ((0, 128, 255), (0, 128, 255)),
    ],
)
def test_road_colours_are_read_as_rgb(given, want):
    assert check_road_colour(given) == want


@pytest.mark.parametrize("bad", ["red", "255,0", "256,0,0", "-1,0,0", "#ff00f", (1.5, 2, 3), (True, 0, 0), b"abc"])
def test_bad_road_colours_are_refused(bad):
    with pytest.raises(InvalidParameterError, match="road_colour: expected the road's colour as R,G,B"):
        check_road_colour(bad)
