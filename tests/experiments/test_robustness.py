"""Physical weather on photographs: deterministic per photo and seed, scored against the
clean photos, and the flags that only apply to photos refused elsewhere."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from simroad import SimroadError
from simroad.cli.main import main
from simroad.detector.registry import load_detector
from simroad.experiments.frames import FrameSet, collect_frames
from simroad.experiments.robustness import PhotoCamera, fit_to_camera, robustness, weathered

pytestmark = pytest.mark.slow  # renders and weathers photo sets

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def photos() -> FrameSet:
    return collect_frames(
        scenarios=("highway",), seeds=(101,), frames_per_seed=2, env_options={"camera_effects": False}
    )


def test_weather_on_photos_is_deterministic_per_seed_and_photo(photos):
    a = weathered(photos, "rain", 0.6, seed=4)
    b = weathered(photos, "rain", 0.6, seed=4)
    c = weathered(photos, "rain", 0.6, seed=5)
    assert all(np.array_equal(x, y) for x, y in zip(a.images, b.images, strict=True))
    assert not np.array_equal(a.images[0], c.images[0])
    assert not np.array_equal(a.images[0], photos.images[0]) and a.noise_masks[0]["rain"].any()
    none = weathered(photos, "rain", 0.0, seed=4)
    assert all(np.array_equal(x, y) for x, y in zip(none.images, photos.images, strict=True))
    # The camera's mounting is the weather's geometry: another pitch, another rain.
    tilted = weathered(photos, "rain", 0.6, seed=4, mount=PhotoCamera(pitch_deg=15.0))
    assert not np.array_equal(tilted.images[0], a.images[0])


def test_robustness_rows_are_shares_of_the_clean_iou(photos):
    factory = lambda f: load_detector("paper", filters=f)  # noqa: E731
    rows, summary = robustness(photos, [(), ("rain_snow",)], ["fog"], [0.3, 0.9], factory, seed=1)
    clean = {r["filters"]: r for r in rows if r["noise"] == "clear"}
    assert all(c["retained"] == 1.0 for c in clean.values())
    for r in rows:
        if r["noise"] == "fog":
            assert r["retained"] == pytest.approx(r["iou"] / clean[r["filters"]]["iou"])
    for s in summary:
        kept = [r["retained"] for r in rows if r["filters"] == s["filters"] and r["noise"] == "fog"]
        assert s["mean_retained"] == pytest.approx(np.mean(kept))
    dense = next(r for r in rows if r["filters"] == "none" and r["severity"] == 0.9)
    assert dense["retained"] < 1.0  # thick fog costs the detector
    with pytest.raises(SimroadError, match="severity"):
        robustness(photos, [()], ["fog"], [1.5], factory)


def test_large_photos_are_scaled_to_the_camera():
    big = FrameSet(images=[np.zeros((1000, 2000, 3), np.uint8)], masks=[np.ones((1000, 2000), bool)],
                   valid=[np.ones((1000, 2000), bool)])  # fmt: skip
    fitted = fit_to_camera(big)
    assert fitted.images[0].shape == (640, 1280, 3) and fitted.masks[0].shape == (640, 1280)


def test_cli_weather_on_a_photo_folder_and_flags_refused_elsewhere(photos, tmp_path, capsys):
    (tmp_path / "img").mkdir()
    (tmp_path / "msk").mkdir()
    for k, (img, mask) in enumerate(zip(photos.images, photos.masks, strict=True)):
        cv2.imwrite(str(tmp_path / "img" / f"p{k}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(tmp_path / "msk" / f"p{k}.png"), mask.astype(np.uint8) * 255)
    base = [sys.executable, "-m", "simroad", "evaluate-detector", "--images", str(tmp_path / "img"),
            "--masks", str(tmp_path / "msk"), "--filters", "none"]  # fmt: skip
    ok = subprocess.run(base + ["--noise", "snow,fog", "--severity", "0.4,0.8", "--plot", str(tmp_path / "r.png")],
                        capture_output=True, text=True, timeout=300, cwd=ROOT)  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    assert "mean_retained" in ok.stdout and (tmp_path / "r.png").stat().st_size > 0
    # The refusals come before any work: this process's command line is enough (a fresh
    # interpreter per case cost seconds of imports; the real run above has one).
    capsys.readouterr()
    for extra, word in ((["--hfov", "90"], "--hfov"), (["--plot", str(tmp_path / "x.png")], "--plot")):
        code = main(["evaluate-detector", *extra])
        err = capsys.readouterr().err
        assert code == 2 and word in err and "without --images" in err and "Traceback" not in err
    code = main(["evaluate-detector", "--noise", "rain,snow"])
    err = capsys.readouterr().err
    assert code == 2 and "lists are for --images" in err and "Traceback" not in err
