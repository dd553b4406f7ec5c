"""Sweeps at the user's camera: the grid's env options from Python, TOML and flags, each
episode run and recorded with them; what the grid sets itself refused there."""

from __future__ import annotations

import json

import pytest

from simroad.cli.main import main
from simroad.errors import InvalidParameterError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid, load_grid_file
from simroad.noise import WindscreenParams

SMALL = {"width": 160, "height": 90, "mount_height_m": 1.6, "forward_offset_m": 1.0, "scenery": 0.0}


def test_every_episode_of_the_grid_gets_the_env_options():
    grid = AblationGrid(scenarios=("highway",), noises=("clear", "rain"), seeds=2, env_options=SMALL, friction=False)
    assert all(s.env_options == {**SMALL, "friction": False} for s in grid.specs())
    assert AblationGrid().fingerprint() == AblationGrid(env_options={}).fingerprint()  # old sweeps still resume
    assert grid.fingerprint() != AblationGrid(scenarios=("highway",), noises=("clear", "rain"), seeds=2,
                                              friction=False).fingerprint()  # fmt: skip
    wiper = AblationGrid(env_options={"windscreen": WindscreenParams(wiper_period_s=1.5)})
    assert json.loads(json.dumps(wiper.fingerprint()))  # a dataclass value digests as its fields


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"noise": "rain"}, "'noise' is set by the grid itself; use its field 'noises'"),
        ({"friction": False}, "use its field 'friction'"),
        ({"duration_s": 5.0}, "use its field 'steps'"),
        ({"widht": 160}, "unknown RoadCam option 'widht'.*Did you mean 'width'"),
        ({"width": 5}, r"width: expected an integer in \[16, 1280\]"),
        ("width=160", "expected a table of RoadCam options"),
    ],
)
def test_bad_env_options_are_refused_by_name(options, words):
    with pytest.raises(InvalidParameterError, match=f"env_options: .*{words}"):
        AblationGrid(env_options=options)


def test_a_grid_file_takes_roadcam_options_at_the_top_or_in_a_table(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text('scenarios = ["highway"]\nwidth = 160\nmount-height-m = 1.6\n[env_options]\nheight = 90\n')
    opts = load_grid_file(path)
    assert opts["env_options"] == {"width": 160, "mount_height_m": 1.6, "height": 90}
    assert AblationGrid(**opts).specs()[0].env_options == {"width": 160, "mount_height_m": 1.6, "height": 90}
    path.write_text("widht = 160\n")
    with pytest.raises(InvalidParameterError, match=r"unknown key 'widht'.*Did you mean 'width'"):
        load_grid_file(path)


def test_a_sweep_at_the_users_camera_runs_and_records_it(tmp_path):
    out = tmp_path / "sweep"
    argv = ["ablate", "--scenarios", "highway", "--noises", "clear", "--filters", "none", "--seeds", "1", "--steps",
            "2", "--workers", "1", "--quiet", "--out", str(out), "--width", "160", "--height", "90", "--mount-height",
            "1.6", "--forward-offset", "1.0", "--scenery", "0"]  # fmt: skip
    assert main(argv) == 0
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert len(rows) == 2 and all(r["env_options"] == {**SMALL, "scenery": 0.0} for r in rows)
    assert json.loads((out / "grid.json").read_text())["grid"]["env_options"]["mount_height_m"] == 1.6
    # the same in Python, resumed in the same folder: nothing to run again
    grid = AblationGrid(scenarios=("highway",), noises=("clear",), filters=("none",), seeds=1, steps=2,
                        env_options={**SMALL, "scenery": 0.0})  # fmt: skip
    assert len(run_ablation(grid, out, workers=1, progress=False)) == 2


def test_episode_and_frames_take_the_mount_height_and_forward_offset(tmp_path, capsys):
    assert main(["episode", "--scenario", "highway", "--steps", "2", "--json", "--width", "160", "--height", "90",
                 "--mount-height", "1.8", "--forward-offset", "1.2"]) == 0  # fmt: skip
    record = json.loads(capsys.readouterr().out)
    assert record["env_options"]["mount_height_m"] == 1.8 and record["env_options"]["forward_offset_m"] == 1.2
    out = tmp_path / "frames"
    assert main(["frames", "--count", "1", "--out", str(out), "--width", "160", "--height", "90", "--mount-height",
                 "2.0", "--quiet"]) == 0  # fmt: skip
    assert json.loads((out / "meta.json").read_text())["camera"]["mount_height_m"] == 2.0
