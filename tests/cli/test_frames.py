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


def test_frames_write_depth_materials_cityscapes_labels_and_noise_masks(tmp_path):
    """The first frame is the reset's: each file decodes to the env's own ground truth."""
    from simroad.camera.codes import ASPHALT, MATERIAL_NAMES, SIDEWALK, SKY, VEGETATION
    from simroad.envs import RoadCamEnv

    out = tmp_path / "town"
    opts = ["--scenario", "town", "--noise", "rain+glare", "--severity", "0.6", "--width", "160", "--height", "90"]
    assert main(["frames", *opts, "--seed", "4", "--count", "2", "--out", str(out), "--quiet"]) == 0
    env = RoadCamEnv(scenario="town", noise="rain+glare", severity=0.6, width=160, height=90)
    _, info = env.reset(seed=4)
    env.close()
    read = lambda name: cv2.imread(str(out / name), cv2.IMREAD_UNCHANGED)  # noqa: E731
    depth, material, labels = read("depth_0000.png"), read("material_0000.png"), read("labels_0000.png")
    assert depth.dtype == np.uint16 and material.dtype == np.uint8 and labels.dtype == np.uint8
    np.testing.assert_array_equal(material, info["material"])
    seen = np.isfinite(info["depth"])
    assert (depth[~seen] == 0).all() and (depth[seen] > 0).all()
    np.testing.assert_allclose(depth[seen] / 100.0, info["depth"][seen], atol=0.005 + 1e-6)
    assert (depth[material == SKY] == 0).all()
    # Cityscapes ids by hand: road 7, sidewalk 8, vegetation 21, sky 23
    for code, label in ((ASPHALT, 7), (SIDEWALK, 8), (VEGETATION, 21), (SKY, 23)):
        assert (material == code).any() and (labels[material == code] == label).all(), MATERIAL_NAMES[code]
    road = read("road_0000.png")
    assert ((road == 255) == info["road_mask"]).all() and (labels[road == 255] == 7).all()
    for name in ("rain", "glare", "windscreen"):
        mask = read(f"noise_{name}_0000.png")
        assert set(np.unique(mask)) == {0, 255}
        np.testing.assert_array_equal(mask == 255, info["noise_masks"][name])
    assert not (out / "noise_snow_0000.png").exists()
    meta = json.loads((out / "meta.json").read_text())
    assert meta["materials"][str(ASPHALT)] == "asphalt" and meta["cityscapes_label_ids"]["kerb"] == 8
    assert "centimetres" in meta["files"]["depth_N.png"] and (out / "labels_0001.png").exists()
