"""Offline evaluation: pooled rates equal those counted by hand; image folders; --model."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad import SimroadError
from simroad.cli.main import main
from simroad.detector import RoadDetector
from simroad.detector.registry import predict_alone
from simroad.errors import InvalidParameterError
from simroad.experiments.evaluate import (
    detector_factory,
    evaluate_detector,
    evaluate_frames,
    figure_panels,
    filter_mask,
    format_table,
    model_factory,
)
from simroad.experiments.frames import collect_frames
from simroad.experiments.photos import load_image_folder
from simroad.metrics.mask import MaskScore


@pytest.fixture(scope="module")
def shadow_frames():
    """Two held-out 160x90 winding frames under shadow."""
    return collect_frames(
        scenarios=("winding",), seeds=(101,), frames_per_seed=2, noise="shadow", severity=0.8,
        env_options={"width": 160, "height": 90},
    )  # fmt: skip


def _pooled(det, frames, *, whole: bool = False) -> tuple[float, float]:
    tp = fn = fp = tn = 0
    for img, gt, valid in zip(frames.images, frames.masks, frames.valid):
        pred = det.predict(img)
        valid = np.ones_like(valid) if whole else valid
        tp += int((pred & gt & valid).sum())
        fn += int((~pred & gt & valid).sum())
        fp += int((pred & ~gt & valid).sum())
        tn += int((~pred & ~gt & valid).sum())
    return fn / (tp + fn), fp / (fp + tn)


def test_rows_are_the_pooled_rates_counted_by_hand(shadow_frames):
    rows, frows = evaluate_frames(shadow_frames, [(), ("shadow",)])
    assert [r["filters"] for r in rows] == ["none", "shadow"] and all(r["frames"] == 2 for r in rows)
    for row, filters in zip(rows, [(), ("shadow",)]):
        fnr, fpr = _pooled(RoadDetector.pretrained(filters=filters), shadow_frames)
        assert row["fnr"] == pytest.approx(fnr, abs=1e-12) and row["fpr"] == pytest.approx(fpr, abs=1e-12)
        fnr_image, fpr_image = _pooled(RoadDetector.pretrained(filters=filters), shadow_frames, whole=True)
        assert row["fnr_image"] == pytest.approx(fnr_image, abs=1e-12)
        assert row["fpr_image"] == pytest.approx(fpr_image, abs=1e-12)
        assert 0.0 <= row["iou"] <= 1.0 and 0.0 <= row["f1"] <= 1.0
    assert not all(v.all() for v in shadow_frames.valid)  # the sky is outside the ground pixels
    # the shadow filter's own mask is scored against the ground-truth shadow mask
    # the shadow filter's own mask as the detector runs it (its variant), scored against the GT shadow mask
    assert [r["mask"] for r in frows] == ["shadow filter (improved) vs GT shadow"]
    assert frows[0]["frames"] == 2 and all(0.0 <= frows[0][k] <= 1.0 for k in ("precision", "recall", "iou", "f1"))
    by_hand = MaskScore()
    for img, noise in zip(shadow_frames.images, shadow_frames.noise_masks):
        by_hand.update(filter_mask("shadow", img, "improved"), noise["shadow"])
    assert frows[0]["recall"] == pytest.approx(by_hand.summary()["recall"]) and frows[0]["recall"] > 0.2


def test_image_folder_and_model_file_give_the_same_rows(shadow_frames, tmp_path):
    images, masks = tmp_path / "img", tmp_path / "mask"
    images.mkdir()
    masks.mkdir()
    for k, (img, gt) in enumerate(zip(shadow_frames.images, shadow_frames.masks)):
        cv2.imwrite(str(images / f"frame_{k:04d}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(masks / f"road_{k:04d}.png"), gt.astype(np.uint8) * 255)
    (images / "unpaired.png").write_bytes((images / "frame_0000.png").read_bytes())
    with pytest.raises(InvalidParameterError, match=r"no mask in .* for unpaired\.png"):
        load_image_folder(images, masks)  # an image without a mask is named, not skipped
    (images / "unpaired.png").unlink()
    folder = load_image_folder(images, masks)
    assert len(folder.images) == 2 and np.array_equal(folder.images[1], shadow_frames.images[1])
    assert np.array_equal(folder.masks[0], shadow_frames.masks[0]) and folder.valid[0].all()

    # the layout `simroad frames` writes: frames and road masks in one folder
    for m in masks.iterdir():
        m.rename(images / m.name)
    same = load_image_folder(images, images)
    assert [s[0] for s in same.source] == ["frame_0000.png", "frame_0001.png"]
    assert all(np.array_equal(a, b) for a, b in zip(same.images, folder.images))
    for m in list(images.glob("road_*")):
        m.rename(masks / m.name)

    model = tmp_path / "model.npz"
    RoadDetector.pretrained().save(model)
    rows, _ = evaluate_detector(["none", "all"], images=images, masks=masks, model=model)
    want, _ = evaluate_frames(folder, [(), ("shadow", "rain_snow", "light")])
    assert rows == want and rows[1]["filters"] == "shadow+rain_snow+light"
    # a photo's whole image is its labelled image: the whole-image rates are the rates
    assert all((r["fnr_image"], r["fpr_image"]) == (r["fnr"], r["fpr"]) for r in rows)


def test_model_factory_reuses_the_loaded_setting_and_sets_others(tmp_path):
    model = tmp_path / "m.npz"
    RoadDetector.pretrained().save(model)
    factory = model_factory(model)
    assert factory(()) is factory(())
    other = factory(("light",))
    assert tuple(other.filters) == ("light",) and other is not factory(())


def test_bad_inputs_are_clear_errors(tmp_path):
    with pytest.raises(SimroadError, match="go together"):
        evaluate_detector(images=tmp_path)
    with pytest.raises(SimroadError, match="not a directory"):
        load_image_folder(tmp_path / "nope", tmp_path)
    with pytest.raises(SimroadError, match="no image"):
        load_image_folder(tmp_path, tmp_path)
    with pytest.raises(SimroadError, match="no model file"):
        evaluate_detector(model=tmp_path / "missing.npz")


def test_format_table_aligns_columns_and_formats_percentages():
    text = format_table([{"filters": "none", "fnr": 0.0123, "iou": 0.5}, {"filters": "all", "fnr": 0.5, "iou": 1.0}],
                        percent=("fnr",))  # fmt: skip
    assert text.splitlines() == ["filters     fnr    iou", "   none   1.23%  0.500", "    all  50.00%  1.000"]
    assert format_table([]) == "(no rows)"


def test_the_figure_shows_the_chosen_detector_weather_and_filters(tmp_path):
    """Its panels are the chosen detector's predict on the chosen weather, per filter
    setting; the command line's --figure passes its flags on."""
    plugin = tmp_path / "lower.py"
    plugin.write_text(
        "import numpy as np\n"
        "class Lower:\n"
        "    def predict(self, image):\n"
        "        mask = np.zeros(image.shape[:2], bool)\n"
        "        mask[image.shape[0] // 2 :] = True\n"
        "        return mask\n"
    )
    spec = f"{plugin}:Lower"
    factory = detector_factory(None, spec, {})
    rows = figure_panels(scenarios=("highway",), noises=("snow",), severity=0.4, settings=[(), ("rain_snow",)],
                         detector_factory=factory)  # fmt: skip
    assert [(r[0], r[1]) for r in rows] == [("highway", "snow")]
    _, _, img, _, masks = rows[0]
    assert [name for name, _ in masks] == ["none", "rain_snow"]
    np.testing.assert_array_equal(masks[0][1], predict_alone(factory(()), img))
    np.testing.assert_array_equal(masks[1][1], predict_alone(factory(("rain_snow",)), img))
    clear = figure_panels(scenarios=("highway",), noises=("clear",), settings=[()], detector_factory=factory)
    assert not np.array_equal(clear[0][2], img)  # the snow is on the frame
    out = tmp_path / "fig.png"
    argv = ["evaluate-detector", "--scenario", "highway", "--seeds", "1", "--frames", "1", "--noise", "snow",
            "--severity", "0.4", "--filters", "none", "--detector", spec, "--figure", str(out)]  # fmt: skip
    assert main(argv) == 0 and out.stat().st_size > 5_000
