"""``simroad calibrate``: refusals by name before any rendering, a small real run, and
``--camera-profile`` reaching the environment of every command that renders."""

from __future__ import annotations

import functools
import json
import os

import cv2
import numpy as np
import pytest

from simroad.camera.profile import CameraProfile, load_profile, save_profile
from simroad.cli import commands, videos
from simroad.cli.main import main
from simroad.cli.parser import build_parser
from simroad.experiments import calibrate as calibrate_module
from simroad.experiments import realism as realism_module
from simroad.experiments.calibrate import CALIBRATION_SEEDS
from simroad.experiments.profile_space import FIT_PARAMETERS
from simroad.metrics.appearance import STATISTICS

PROFILE = CameraProfile(exposure_bias_ev=0.8, wb_preset_k=4200.0, tone_gamma=1.3, asphalt_scale=1.4)


def _photos(root, mask_of=lambda k, road: road, n=3):
    """``n`` synthetic 96 x 64 road photos (sky, verge, grey road) and masks ``mask_of(k, road)``."""
    photos, masks = root / "photos", root / "masks"
    photos.mkdir()
    masks.mkdir()
    for k in range(n):
        rgb = np.empty((64, 96, 3), np.uint8)
        rgb[:32] = (175, 195, 225)
        rgb[32:] = (80, 120, 60)
        road = np.zeros((64, 96), np.uint8)
        road[40:, 20:76] = 255
        rgb[road > 0] = (95 + 5 * k, 97 + 5 * k, 104 + 5 * k)
        cv2.imwrite(str(photos / f"shot{k}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        mask = mask_of(k, road)
        if mask is not None:
            cv2.imwrite(str(masks / f"shot{k}.png"), mask)
    return photos, masks


@pytest.fixture
def no_rendering(monkeypatch):
    def fail(*args, **kwargs):
        raise AssertionError("rendered before refusing")

    monkeypatch.setattr(calibrate_module, "collect_frames", fail)
    monkeypatch.setattr(calibrate_module, "record_worlds", fail)


def test_defaults_are_the_librarys():
    args = build_parser().parse_args(["calibrate", "--photos", ".", "--masks", ".", "--out", "c.toml"])
    assert range(args.seed_start, args.seed_start + args.seeds) == CALIBRATION_SEEDS
    assert (args.frames, args.max_evaluations, args.max_replays, args.workers) == (1, 24, 200, None)
    assert tuple(args.fit) == FIT_PARAMETERS and args.scenarios == ("racetrack", "highway", "winding", "town")


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--photos", "{tmp}/nowhere"], "argument --photos: "),
        (["--out", "{tmp}/camera.json"], "argument --out: "),
        (["--out", "{tmp}"], "is a directory"),
        (["--fit", "tone_gama"], "Did you mean 'tone_gamma'"),
        (["--max-evaluations", "0"], "--max-evaluations"),
        (["--max-replays", "0"], "--max-replays"),
        (["--workers", "0"], "--workers"),
        (["--seeds", "2", "--seed-start", "2147483647"], "largest seed"),
    ],
)
def test_bad_options_are_refused_by_name(no_rendering, argv, words, tmp_path, capsys):
    photos, masks = _photos(tmp_path)
    base = {"--photos": str(photos), "--masks": str(masks), "--out": str(tmp_path / "c.toml")}
    given = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    for flag, value in base.items():
        if flag not in given:
            given += [flag, value]
    assert main(["calibrate", *given, "--quiet"]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "c.toml").exists()


@pytest.mark.parametrize(
    ("mask_of", "n", "words"),
    [
        (lambda k, road: None, 3, "no mask in"),
        (lambda k, road: road[:32] if k == 1 else road, 3, "shot1.png is (96, 32) but shot1.png is (96, 64)"),
        (lambda k, road: road * 0, 3, "shot0.png marks no road pixel"),
        (lambda k, road: road, 0, "photos: no image in"),
    ],
    ids=["no-masks", "wrong-size", "no-road", "no-photos"],
)
def test_unusable_photos_are_refused(no_rendering, mask_of, n, words, tmp_path, capsys):
    photos, masks = _photos(tmp_path, mask_of, n)
    out = tmp_path / "c.toml"
    assert main(["calibrate", "--photos", str(photos), "--masks", str(masks), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("simroad calibrate: error: ") and words in err
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_an_unwritable_output_is_refused(no_rendering, tmp_path, capsys):
    photos, masks = _photos(tmp_path)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        argv = ["--photos", str(photos), "--masks", str(masks), "--out", str(locked / "c.toml")]
        assert main(["calibrate", *argv]) == 2
    finally:
        locked.chmod(0o700)
    assert "argument --out" in capsys.readouterr().err


@pytest.mark.slow
def test_a_small_real_run_prints_the_table_and_writes_the_profile(tmp_path, capsys):
    photos, masks = _photos(tmp_path)
    out = tmp_path / "camera.toml"
    argv = ["--photos", str(photos), "--masks", str(masks), "--out", str(out), "--scenarios", "highway",
            "--seeds", "1", "--frames", "1", "--max-evaluations", "3", "--fit", "exposure_bias_ev,tone_gamma", "--quiet"]  # fmt: skip
    assert main(["calibrate", *argv]) == 0
    printed = capsys.readouterr().out
    assert "KS start" in printed and "KS fitted" in printed and f"wrote {out}" in printed
    assert all(f"\n{s} " in printed for s in STATISTICS)
    fitted = load_profile(out)
    assert (fitted.wb_preset_k, fitted.asphalt_scale) == (CameraProfile().wb_preset_k, 1.0)  # not fitted
    assert f"photos: 3 photographs in {photos}" in out.read_text()


# --- --camera-profile on every command that renders ----------------------------------


@pytest.fixture
def profile_file(tmp_path):
    path = tmp_path / "camera.toml"
    save_profile(PROFILE, path)
    return path


def test_a_bad_profile_file_is_refused_by_flag_and_key(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera_profile]\ntone_gama = 1.2\n")
    assert main(["episode", "--camera-profile", str(bad), "--steps", "1"]) == 2
    err = capsys.readouterr().err
    assert "argument --camera-profile" in err and "'tone_gama'" in err and "Did you mean 'tone_gamma'" in err
    bad.write_text("[camera_profile]\nasphalt_scale = 9.0\n")
    assert main(["frames", "--camera-profile", str(bad), "--out", str(tmp_path / "f")]) == 2
    assert "asphalt_scale" in capsys.readouterr().err


def _capture(monkeypatch, name):
    seen = {}
    module = videos if name == "write_videos" else commands  # each command's own module
    target = getattr(module, name)

    @functools.wraps(target)
    def fake(*args, **kwargs):
        seen.update(kwargs, args=args)
        raise SystemExit(0)

    monkeypatch.setattr(module, name, fake)
    return seen


@pytest.mark.parametrize(
    ("argv", "library", "key"),
    [
        (["train-detector", "--out", "{tmp}/m.npz"], "train_detector", "camera_profile"),
        (["evaluate-detector"], "evaluate_detector", "camera_profile"),
        (["filter-effect", "--noises", "shadow"], "filter_effect_table", "camera_profile"),
        (["figure", "camera", "--out", "{tmp}/c.png"], "camera_figure", "camera_profile"),
        (["figure", "places", "--out", "{tmp}/c.png"], "places_figure", "camera_profile"),
        (["videos", "--out", "{tmp}/v"], "write_videos", "camera_profile"),
        (["episode"], "run_episode", "args"),
    ],
)
def test_the_flag_reaches_the_library(monkeypatch, profile_file, tmp_path, argv, library, key):
    seen = _capture(monkeypatch, library)
    with pytest.raises(SystemExit):
        main([a.replace("{tmp}", str(tmp_path)) for a in argv] + ["--camera-profile", str(profile_file)])
    got = seen[key][0].env_options["camera_profile"] if key == "args" else seen[key]
    assert got == PROFILE


def test_ablate_and_realism_pass_it_on(monkeypatch, profile_file, tmp_path):
    seen = _capture(monkeypatch, "run_ablation")
    with pytest.raises(SystemExit):
        main(["ablate", "--out", str(tmp_path / "a"), "--camera-profile", str(profile_file), "--quiet"])
    assert seen["args"][0].camera_profile == PROFILE
    got = {}

    @functools.wraps(realism_module.realism_report)  # the parser reads its defaults
    def fake_report(**kw):
        got.update(kw)
        raise SystemExit(0)

    monkeypatch.setattr("simroad.cli.realism.realism_report", fake_report)
    with pytest.raises(SystemExit):
        main(["realism", "--camera-profile", str(profile_file), "--out", str(tmp_path / "r"), "--quiet"])
    assert got["env_options"] == {"camera_profile": PROFILE}


def test_the_flag_is_refused_where_nothing_renders_with_it(profile_file, tmp_path, capsys):
    assert main(["figure", "friction", "--out", str(tmp_path / "f.png"), "--camera-profile", str(profile_file)]) == 2
    assert "--camera-profile: does not apply to the friction figure" in capsys.readouterr().err
    photos, masks = _photos(tmp_path)
    argv = ["evaluate-detector", "--images", str(photos), "--masks", str(masks), "--camera-profile", str(profile_file)]
    assert main(argv) == 2
    assert "--camera-profile: does not apply with --images" in capsys.readouterr().err


def test_frames_reach_the_env_and_meta_json_records_the_profile(profile_file, tmp_path):
    out = tmp_path / "frames"
    assert main(["frames", "--scenario", "highway", "--count", "1", "--out", str(out), "--camera-profile",
                 str(profile_file), "--quiet"]) == 0  # fmt: skip
    meta = json.loads((out / "meta.json").read_text())
    assert meta["camera_profile"] == PROFILE.as_dict()
