"""The command line: help on every subcommand, ``python -m simroad``, defaults read from
the library, the demo's videos through the same CLI."""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import re
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from simroad.camera.geometry import CameraConfig
from simroad.cli.main import main
from simroad.cli.parser import build_parser
from simroad.envs import RoadCamConfig, RoadCamEnv
from simroad.experiments.demo import DEMO_NOISES, write_videos
from simroad.experiments.episode import EpisodeSpec
from simroad.experiments.export import export_frames
from simroad.experiments.grid import AblationGrid


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(action.choices)


SUBCOMMANDS = sorted(_subcommands())


def test_the_parser_has_the_documented_subcommands():
    assert set(SUBCOMMANDS) >= {"frames", "episode", "ablate", "report", "train-detector", "evaluate-detector",
                                "filter-effect", "figure", "videos"}  # fmt: skip


@pytest.mark.parametrize("cmd", SUBCOMMANDS)
def test_every_subcommand_has_help(cmd, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([cmd, "--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: simroad {cmd}")
    sub = _subcommands()[cmd]
    for action in sub._actions:  # every option explains itself
        assert action.help, f"{cmd} {action.option_strings or action.dest} has no help"


@pytest.mark.slow  # a fresh interpreter importing simroad: seconds
def test_python_dash_m_simroad_runs_the_cli(tmp_path):
    # one subprocess (imports cost seconds): __main__ dispatches to main and its exit status
    res = subprocess.run([sys.executable, "-m", "simroad", "frames", "--scenario", "higway", "--out", str(tmp_path / "x")],
                         capture_output=True, text=True)  # fmt: skip
    assert res.returncode == 2 and "simroad frames: error: scenario" in res.stderr
    assert "Did you mean 'highway'" in res.stderr and not (tmp_path / "x").exists()


def _field_defaults(cls) -> dict:
    return {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}


def test_defaults_are_the_librarys():
    spec, cam = _field_defaults(EpisodeSpec), _field_defaults(CameraConfig)
    args = build_parser().parse_args(["episode"])
    assert (args.scenario, args.noise, args.severity) == (spec["scenario"], spec["noise"], spec["severity"])
    assert (args.driver, args.seed, args.steps, args.filters) == (spec["driver"], spec["seed"], spec["steps"], "none")
    assert (args.width, args.height, args.hfov, args.pitch) == (cam["width"], cam["height"], cam["hfov_deg"], cam["pitch_deg"])  # fmt: skip
    frames = build_parser().parse_args(["frames", "--out", "x"])
    sig = inspect.signature(export_frames).parameters
    assert (frames.seed, frames.count, frames.every) == tuple(sig[k].default for k in ("seed", "count", "every"))
    # ablate flags stay unset so a --config file can fill them; the grid supplies the rest
    ablate = build_parser().parse_args(["ablate"])
    assert all(getattr(ablate, k) is None for k in ("scenarios", "seeds", "steps", "filters"))
    grid = _field_defaults(AblationGrid)
    help_text = _subcommands()["ablate"].format_help()
    assert f"(default: {grid['seeds']})" in help_text and f"(default: {grid['steps']})" in help_text
    videos = build_parser().parse_args(["videos", "--out", "x"])
    sig = inspect.signature(write_videos).parameters
    assert (videos.scenario, videos.steps, videos.severity) == tuple(sig[k].default for k in ("scenario", "steps", "severity"))  # fmt: skip


@pytest.mark.slow
def test_videos_subcommand_writes_one_gif_per_noise(tmp_path, capsys):
    out = tmp_path / "videos"
    assert main(["videos", "--out", str(out), "--steps", "2", "--quiet"]) == 0
    for noise in DEMO_NOISES:
        frames = imageio.mimread(out / f"{noise}.gif")
        assert len(frames) == 2 and frames[0].shape[:2] == (180, 2 * 320 + 2)  # without | with filters
    assert capsys.readouterr().out.startswith("videos: ")


def test_videos_take_the_detector_and_filters_and_say_so_in_a_caption(tmp_path, capsys):
    from simroad.experiments.episode import EpisodeSpec, video_caption

    plugin = tmp_path / "marker.py"
    plugin.write_text(
        "import numpy as np, pathlib\n"
        "class Marker:\n"
        f"    def predict(self, image):\n        pathlib.Path({str(tmp_path / 'ran')!r}).touch()\n"
        "        return np.ones(image.shape[:2], bool)\n"
    )
    out = tmp_path / "videos"
    argv = [
        "videos",
        "--out",
        str(out),
        "--steps",
        "2",
        "--quiet",
        "--detector",
        f"{plugin}:Marker",
        "--filters",
        "none",
    ]
    assert main(argv) == 0 and (tmp_path / "ran").exists()
    with_caption = imageio.mimread(out / "rain.gif")[0]
    spec = EpisodeSpec(scenario="winding", noise="rain", severity=0.7, detector=f"{plugin}:Marker", seed=0)
    assert video_caption(spec) == f"winding world 0, rain 0.7: {plugin}:Marker, filters none"
    assert video_caption(EpisodeSpec(driver="oracle")) == "racetrack world 0, clear: oracle (ground truth)"
    band, below = with_caption[:8, :60, :3].mean(), with_caption[16:40, :60, :3].mean()
    assert band < 0.6 * below, (band, below)  # the caption's dark band over the sky
    assert main(["videos", "--out", str(out), "--filters", "bogus", "--quiet"]) == 2


def test_scenery_and_camera_effects_flags_reach_the_environment(tmp_path):
    args = build_parser().parse_args(["frames", "--out", "x"])
    assert args.scenery == RoadCamConfig().scenery and args.no_camera_effects is False
    # Frames written with the flags equal the environment's own with the same options.
    out = tmp_path / "f"
    flags = ["--scenery", "0", "--no-camera-effects", "--count", "1", "--seed", "5", "--quiet"]
    assert main(["frames", "--scenario", "highway", "--out", str(out), *flags]) == 0
    written = imageio.imread(out / "frame_0000.png")
    env = RoadCamEnv(scenario="highway", scenery=0.0, camera_effects=False)
    obs, _ = env.reset(seed=5)
    np.testing.assert_array_equal(written, obs)


@pytest.mark.parametrize("value", ["-1", "6", "lots"])
def test_a_bad_scenery_density_is_refused_by_name(value, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["frames", "--out", "x", "--scenery", value])
    assert "--scenery" in capsys.readouterr().err


def test_the_qualitative_figure_draws_the_scored_held_out_world(monkeypatch, tmp_path):
    import simroad.cli.commands as commands

    drawn = {}
    monkeypatch.setattr(commands, "evaluate_detector", lambda *a, **k: ([], []))
    monkeypatch.setattr(commands, "qualitative_figure", lambda path, **k: drawn.update(k) or path)
    assert main(["evaluate-detector", "--seed-start", "123", "--figure", str(tmp_path / "q.png")]) == 0
    assert drawn["seed"] == 123 and drawn["scenarios"] == ("winding",) and drawn["severity"] == 0.7
    assert drawn["noises"] == ("glare", "shadow", "snow", "rain") and drawn["settings"] == [
        (),
        ("shadow", "rain_snow", "light"),
    ]
    assert main(["evaluate-detector", "--seed-start", "123", "--scenario", "town", "--noise", "fog", "--severity", "0.3",
                 "--filters", "none,rain_snow", "--figure", str(tmp_path / "q.png")]) == 0  # fmt: skip
    assert (drawn["scenarios"], drawn["noises"], drawn["severity"]) == (("town",), ("fog",), 0.3)
    assert drawn["settings"] == [(), ("rain_snow",)] and drawn["detector_name"] == "paper"
    assert main(["evaluate-detector", "--figure", str(tmp_path / "q.png")]) == 0
    assert drawn["seed"] >= 100  # the default: held out, never a training world (0-15)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["evaluate-detector", "--filters", "none,none"], r"--filters: 'none' is listed more than once"),
        (["filter-effect", "--noises", "rain,rain"], r"--noises: 'rain' is listed more than once"),
        (["filter-effect", "--variant", "paper,paper"], r"--variant: 'paper' is listed more than once"),
        (["filter-effect", "--severity", "0.5,0.50"], r"--severity: 0.5 is listed more than once"),
        (["ablate", "--out", "{tmp}/s", "--severities", "0.5,,0.7"], r"--severities: empty item in '0.5,,0.7'"),
        (["ablate", "--out", "{tmp}/s", "--noises", "rain,,snow"], r"--noises: empty item in 'rain,,snow'"),
        (["ablate", "--out", "{tmp}/s", "--scenarios", "racetrack,"], r"--scenarios: empty item in 'racetrack,'"),
    ],
)
def test_comma_lists_refuse_empty_and_repeated_items(argv, words, tmp_path, capsys, monkeypatch):
    """A dropped empty item or a repeated one was silently skipped or scored twice."""
    from simroad.cli import commands

    monkeypatch.setattr(commands, "run_ablation", lambda *a, **k: pytest.fail("the sweep started"))
    monkeypatch.setattr(RoadCamEnv, "reset", lambda *a, **k: pytest.fail("an episode started"))
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert re.search(words, err), err


def test_version_flag_prints_the_version_of_the_package(capsys):
    import tomllib

    import simroad

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"simroad {simroad.__version__}"
    pyproject = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())
    assert pyproject["project"]["version"] == simroad.__version__  # one version, stated twice
