"""`simroad frames` writes a ready data set; bad input exits 2 with a clear message.

(Help on every subcommand is tested in test_cli.py.)"""

from __future__ import annotations

import json

import cv2
import numpy as np

from simroad.cli.main import main


def test_frames_writes_pngs_masks_and_meta(tmp_path):
    out = tmp_path / "ds"
    code = main(
        [
            "frames",
            "--scenario",
            "winding",
            "--seed",
            "3",
            "--count",
            "4",
            "--out",
            str(out),
            "--quiet",
            "--width",
            "160",
            "--height",
            "90",
        ]
    )
    assert code == 0
    for k in range(4):
        frame = cv2.imread(str(out / f"frame_{k:04d}.png"))
        road = cv2.imread(str(out / f"road_{k:04d}.png"), cv2.IMREAD_GRAYSCALE)
        assert frame.shape == (90, 160, 3)
        assert set(np.unique(road)) <= {0, 255} and (road == 255).mean() > 0.2
    meta = json.loads((out / "meta.json").read_text())
    assert meta["camera"]["width"] == 160 and len(meta["camera"]["K"]) == 3
    assert len(meta["frames"]) == 4
    assert meta["env"]["noise"] == "clear" and meta["env"]["severity"] == 0.0  # clear frames have no severity
    xs = [f["x_m"] for f in meta["frames"]]
    assert xs == sorted(xs) and xs[-1] > xs[0]  # the car drove forward


def test_unwritable_out_exits_2_with_message(tmp_path, capsys):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    code = main(["frames", "--count", "1", "--out", str(blocker / "sub"), "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert "out" in err and "writable" in err


def test_unknown_scenario_exits_2_and_suggests(tmp_path, capsys):
    out = tmp_path / "never"
    code = main(["frames", "--scenario", "higway", "--count", "1", "--out", str(out), "--quiet"])
    assert code == 2
    assert "Did you mean 'highway'" in capsys.readouterr().err
    assert not out.exists()  # nothing written before the input was checked
