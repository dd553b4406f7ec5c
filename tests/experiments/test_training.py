"""``simroad train-detector``: a real (tiny) training written where --out says, never
into the package; an unwritable destination fails before any frame is rendered."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from simroad import SimroadError
from simroad.cli.main import main
from simroad.detector import RoadDetector, default_model_path
from simroad.experiments import training
from simroad.experiments.frames import collect_frames
from simroad.experiments.training import DEFAULT_MODEL_FILE, check_writable_file, train_detector


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_training_writes_to_the_working_directory_by_default(tmp_path, monkeypatch):
    shipped = _digest(default_model_path())
    monkeypatch.chdir(tmp_path)
    path = train_detector(seeds=(0,), frames_per_seed=1, scenarios=("racetrack",))
    assert path.resolve() == (tmp_path / DEFAULT_MODEL_FILE).resolve() and path.is_file()
    assert _digest(default_model_path()) == shipped  # the installed package is untouched

    det = RoadDetector.load(path)
    held_out = collect_frames(scenarios=("racetrack",), seeds=(100,), frames_per_seed=1)
    img, gt, valid = held_out.images[0], held_out.masks[0], held_out.valid[0]
    pred = det.predict(img)
    assert pred.shape == gt.shape and pred.dtype == bool
    assert (pred == gt)[valid].mean() > 0.8  # one training frame still finds the road
    # the same seeds give the same model
    again = train_detector(tmp_path / "again.npz", seeds=(0,), frames_per_seed=1, scenarios=("racetrack",))
    assert np.array_equal(RoadDetector.load(again).predict(img), pred)


def _no_rendering(**_):
    raise AssertionError("frames were rendered before the destination was checked")


def test_unwritable_destination_fails_before_training(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(training, "collect_frames", _no_rendering)
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    with pytest.raises(SimroadError, match="out"):
        train_detector(blocker / "model.npz")
    with pytest.raises(SimroadError, match="is a directory"):
        train_detector(tmp_path)
    assert main(["train-detector", "--out", str(blocker / "sub" / "m.npz")]) == 2
    assert "train-detector: error: out" in capsys.readouterr().err


def test_check_writable_file_creates_missing_folders(tmp_path):
    path = check_writable_file("out", tmp_path / "a" / "b" / "m.npz")
    assert path.parent.is_dir() and not path.exists()


def test_cli_default_out_is_in_the_working_directory():
    from simroad.cli.parser import build_parser

    args = build_parser().parse_args(["train-detector"])
    assert args.out == DEFAULT_MODEL_FILE == "road_detector.npz"
    assert (args.seeds, args.seed_start, args.frames) == (len(training.TRAIN_SEEDS), 0, training.TRAIN_FRAMES_PER_SEED)
