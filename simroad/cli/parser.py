"""Define the ``simroad`` subcommands and their options, every default read from the library.

Defaults come from the dataclasses and function signatures that own them
(:class:`EpisodeSpec`, :class:`AblationGrid`, :class:`CameraConfig`, ...), and the
names listed in the help from the library's registries, so the command line never
restates a number.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from simroad.cli import commands
from simroad.cli import types as T
from simroad.cli.calibrate import add_calibrate
from simroad.cli.env_options import (
    MASK_FORMATS,
    add_camera_profile,
    add_detector_flags,
    add_env_options,
    add_mask_format,
    add_sweep_camera,
    default_of,
    names,
)
from simroad.cli.index import COMMANDS, command_parser
from simroad.cli.realism import add_realism
from simroad.cli.videos import add_videos
from simroad.control.drivers import DRIVER_NAMES
from simroad.core.names import NOISE_NAMES, TRAIN_SEEDS
from simroad.envs.config import RoadCamConfig
from simroad.envs.scenarios import SCENARIO_NAMES
from simroad.experiments._ray_backend import check_ray_address
from simroad.experiments.ablate import BACKENDS, run_ablation
from simroad.experiments.episode import EpisodeSpec
from simroad.experiments.evaluate import evaluate_detector
from simroad.experiments.export import export_frames
from simroad.experiments.figures import camera_figure, figure_suffixes
from simroad.experiments.filter_effect import filter_effect_table
from simroad.experiments.grid import AblationGrid
from simroad.experiments.robustness import PhotoCamera
from simroad.experiments.training import DEFAULT_MODEL_FILE, TRAIN_FRAMES_PER_SEED
from simroad.filters import FILTER_NAMES, FILTER_VARIANTS, apply_filters, format_filters

__all__ = ["build_parser"]


_NOISE = T.weather()
_FILTERS = T.filter_set()
_NOISES = T.weather_list()
_FILTER_SETS = T.filter_set_list()
_UNIT = T.float_in(0.0, 1.0)
_INT = T.int_in(1, 100_000)  # image sizes: the camera checks its own range
_STEPS = T.int_in(1, 1_000_000)
_COUNT = T.int_in(1, 100_000)


def _shown(value: Any) -> str:
    """A default as the user would type it (lists comma-joined)."""
    return ",".join(str(v) for v in value) if isinstance(value, (tuple, list)) else f"{value}"


def _command(sub: Any, name: str, *, description: str) -> Any:
    """The subparser of command ``name``, its one-line help from :data:`COMMANDS`."""
    return sub.add_parser(name, help=COMMANDS[name], description=description)


def _add_episode_seed(p: Any, default: int) -> None:
    """``--seed``: the seed of the (one) episode."""
    p.add_argument("--seed", type=T.seed(), default=default, help=f"episode seed (default: {default})")


def _add_held_out_seeds(p: Any, seeds: Sequence[int]) -> None:
    """``--seeds`` and ``--seed-start`` of consecutive held-out seeds; by default as
    many as the library's ``seeds``, from the first of them."""
    p.add_argument("--seeds", type=_COUNT, default=len(seeds), help=f"number of held-out seeds (default: {len(seeds)})")
    p.add_argument("--seed-start", type=T.seed(), default=seeds[0], help=f"first seed (default: {seeds[0]})")


def _add_quiet(p: Any) -> None:
    """``--quiet``: no progress bar."""
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_frames(sub: Any) -> None:
    p = _command(
        sub,
        "frames",
        description="Drive the ground-truth autopilot and write frame_NNNN.png, road_NNNN.png (GT 0/255) and meta.json (camera intrinsics, pose per frame).",
    )
    add_env_options(p, RoadCamConfig)
    d = {k: default_of(export_frames, k) for k in ("seed", "count", "every")}
    _add_episode_seed(p, d["seed"])
    p.add_argument(
        "--count", type=T.int_in(1, 100_000), default=d["count"], help=f"number of frames (default: {d['count']})"
    )
    p.add_argument(
        "--every",
        type=T.int_in(1, 1000),
        default=d["every"],
        help=f"policy steps between frames (default: {d['every']})",
    )
    p.add_argument("--out", type=T.output_dir(), required=True, help="output directory (created)")
    _add_quiet(p)
    p.set_defaults(func=commands.cmd_frames)


def _add_episode(sub: Any) -> None:
    p = _command(
        sub,
        "episode",
        description="Drive one episode: the camera frame goes to the driver (the road detector + lane keeping, or the oracle on the ground-truth mask); the episode is scored on the mask (FNR/FPR) and on safety. Exit status 1 if a --require fails.",
    )
    add_env_options(p, EpisodeSpec)
    d = {k: default_of(EpisodeSpec, k) for k in ("filters", "driver", "seed", "steps")}
    filters = format_filters(d["filters"])
    p.add_argument(
        "--filters",
        type=_FILTERS,
        default=filters,
        help=f"detector filters: none, all, or names joined by '+' ({names(FILTER_NAMES)}), e.g. shadow+light (default: {filters})",
    )
    p.add_argument(
        "--driver",
        type=T.choice(DRIVER_NAMES),
        default=d["driver"],
        help=f"{names(DRIVER_NAMES)} (default: {d['driver']})",
    )
    add_detector_flags(p)
    _add_episode_seed(p, d["seed"])
    p.add_argument(
        "--steps",
        type=_STEPS,
        default=d["steps"],
        help=f"maximum policy steps, one camera frame and action each (default: {d['steps']})",
    )
    p.add_argument(
        "--route-m",
        type=T.float_in(1.0, 1e6, unit="m"),
        default=None,
        help="route length in m (default: the scenario's route -- one racetrack lap or 1 km -- capped at what 80%% of the cruise speed covers in --steps)",
    )
    p.add_argument(
        "--video",
        type=T.output_file(lambda: (".mp4", ".gif")),
        default=None,
        help="write an .mp4 or .gif of the episode",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object with the record")
    p.add_argument(
        "--require",
        action="append",
        default=[],
        metavar="KEY<=VALUE",
        help="a gate such as 'offroad_fraction<=0.01' (any record key; <, <=, >, >=); repeatable",
    )
    p.set_defaults(func=commands.cmd_episode)


def _add_ablate(sub: Any) -> None:
    p = _command(
        sub,
        "ablate",
        description="Run detectors x filter sets x scenarios x noises x severities x seeds, plus one oracle episode per scenario x noise x severity x seed; results are appended to OUT/results.jsonl as each episode finishes (rerun to resume), then summary.csv/json/md (means with 95 % bootstrap or Clopper-Pearson intervals), paired.csv/json (filters vs none in the same worlds and seeds), error_rates.png, safety.png and paired.png are written.",
    )
    d = {k: _shown(default_of(AblationGrid, k)) for k in commands.ABLATE_GRID_FLAGS}
    p.add_argument("--config", type=T.input_file(), help="a TOML file with the same names as keys (flags override it)")
    p.add_argument(
        "--scenarios",
        type=T.choice_list(SCENARIO_NAMES),
        help=f"comma-separated: {names(SCENARIO_NAMES)} (default: {d['scenarios']})",
    )
    p.add_argument(
        "--noises",
        type=_NOISES,
        help=f"comma-separated: {names(NOISE_NAMES)} or compositions like rain+glare (default: {d['noises']})",
    )
    p.add_argument(
        "--severities",
        type=T.float_list(0.0, 1.0),
        help=f"comma-separated values in [0, 1] (default: {d['severities']})",
    )
    p.add_argument(
        "--filters",
        type=_FILTER_SETS,
        help=f"comma-separated filter sets: none, all, or names joined by '+' ({names(FILTER_NAMES)}) (default: {d['filters']})",
    )
    p.add_argument(
        "--detectors",
        type=T.detector_specs(),
        help="comma-separated detector specs: paper, registered names, package.module:attr or "
        f"path/to/file.py:attr (default: {d['detectors']}); their options go in the TOML file's "
        '[detector-options."SPEC"] tables, or --detector-option',
    )
    p.add_argument(
        "--detector-option",
        dest="detector_option",
        type=T.detector_option(targeted=True),
        action="append",
        default=[],
        metavar="SPEC@KEY=VALUE",
        help="keyword option for one of --detectors (SPEC@KEY=VALUE; KEY=VALUE when one detector besides "
        "paper is given); repeatable",
    )
    p.add_argument(
        "--no-friction",
        action="store_true",
        help="every episode without tyre-road friction (highway-env's unlimited dynamics; default: friction from "
        "the weather; friction = false in --config), to separate what the weather costs perception from what it costs the dynamics",
    )
    p.add_argument("--seeds", type=_COUNT, help=f"number of seeds (default: {d['seeds']})")
    p.add_argument("--seed-start", dest="seed_start", type=T.seed(), help=f"first seed (default: {d['seed_start']})")
    p.add_argument("--steps", type=_STEPS, help=f"policy steps per episode (default: {d['steps']})")
    p.add_argument("--workers", type=T.int_in(1, 4096), help="parallel episodes (default: all cores)")
    p.add_argument(
        "--backend", type=T.choice(BACKENDS), help=f"{names(BACKENDS)} (default: {default_of(run_ablation, 'backend')})"
    )
    p.add_argument(
        "--ray-address",
        dest="ray_address",
        type=T.checked(check_ray_address, "ray_address"),
        help="Ray cluster address, HOST:PORT or auto (with --backend ray)",
    )
    p.add_argument("--out", type=T.output_dir(), help="output directory")
    p.add_argument("--fresh", action="store_true", help="delete results of a different grid in --out and start anew")
    add_sweep_camera(p)
    _add_quiet(p)
    p.set_defaults(func=commands.cmd_ablate)

    p = _command(
        sub,
        "report",
        description="Rebuild summary.csv, summary.md, summary.json, paired.csv, paired.json, error_rates.png, safety.png and paired.png from DIR/results.jsonl (the same file gives the same report, byte for byte). With several DIRs (sweeps of other detectors, filters or seeds), --out gets one report over all their rows, paired wherever they share worlds and seeds.",
    )
    p.add_argument("dir", nargs="+", type=T.input_dir(), help="sweep output directories (each with results.jsonl)")
    p.add_argument("--out", type=T.output_dir(), help="folder of a report over several DIRs (default: DIR itself)")
    p.set_defaults(func=commands.cmd_report)


def _add_detector(sub: Any) -> None:
    p = _command(
        sub,
        "train-detector",
        description="Render clean frames of every scenario (one world palette per seed), fit the default SVM detector and save it as npz (no pickle) to --out; the destination is checked before training. Use the file with RoadDetector.load(PATH) or evaluate-detector --model PATH.",
    )
    p.add_argument("--out", default=DEFAULT_MODEL_FILE, help=f"output .npz (default: ./{DEFAULT_MODEL_FILE})")
    p.add_argument(
        "--seeds",
        type=_COUNT,
        default=len(TRAIN_SEEDS),
        help=f"number of training worlds (default: {len(TRAIN_SEEDS)})",
    )
    p.add_argument(
        "--seed-start",
        type=T.seed(),
        default=TRAIN_SEEDS[0],
        help=f"first seed (default: {TRAIN_SEEDS[0]}; evaluation uses seeds >= 100)",
    )
    p.add_argument(
        "--frames",
        type=_COUNT,
        default=TRAIN_FRAMES_PER_SEED,
        help=f"frames per scenario and seed (default: {TRAIN_FRAMES_PER_SEED})",
    )
    add_camera_profile(p)
    p.set_defaults(func=commands.cmd_train)

    d = {
        k: default_of(evaluate_detector, k)
        for k in ("settings", "scenarios", "noise", "severity", "seeds", "frames_per_seed")
    }
    p = _command(
        sub,
        "evaluate-detector",
        description="Score the shipped detector (or --model) on rendered frames (held-out seeds) or on a folder of real images and masks, for each filter setting; also score the filters' own masks against the ground-truth noise masks.",
    )
    p.add_argument(
        "--scenario",
        type=T.choice_list(SCENARIO_NAMES),
        default=_shown(d["scenarios"]),
        help=f"comma-separated scenarios (default: {_shown(d['scenarios'])})",
    )
    p.add_argument(
        "--noise",
        type=_NOISES,
        default=[d["noise"]],
        help=f"weather of the rendered frames (default: {d['noise']}); with --images, comma-separated weathers "
        "put on the photos, each scored against the clean photos",
    )
    p.add_argument(
        "--severity",
        type=T.float_list(0.0, 1.0),
        default=[d["severity"]],
        help=f"weather severity in [0, 1] (default: {d['severity']}); with --images, comma-separated severities",
    )
    p.add_argument(
        "--filters",
        type=_FILTER_SETS,
        default=_shown(d["settings"]),
        help=f"comma-separated filter settings (default: {_shown(d['settings'])})",
    )
    _add_held_out_seeds(p, d["seeds"])
    p.add_argument(
        "--frames",
        type=_COUNT,
        default=d["frames_per_seed"],
        help=f"frames per scenario and seed (default: {d['frames_per_seed']})",
    )
    p.add_argument("--images", type=T.input_dir(), help="folder of real images (instead of rendered frames)")
    masks = f"folder of their road masks (same file names, or road_N for frame_N): {MASK_FORMATS}"
    p.add_argument("--masks", type=T.input_dir(), help=masks)
    add_mask_format(p)
    p.add_argument(
        "--model",
        type=T.input_file(),
        help="a detector .npz (e.g. from train-detector) to evaluate instead of the shipped one",
    )
    p.add_argument(
        "--figure",
        type=T.output_file(figure_suffixes),
        help="also draw the paper's qualitative figure (Figs. 3-6) to this PNG",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    add_detector_flags(p)
    photo = PhotoCamera()
    g = p.add_argument_group("weather on photographs (with --images and --noise)")
    g.add_argument("--weather-seed", type=T.seed(), default=0, help="seed of the weather on the photos (default: 0)")
    g.add_argument(
        "--hfov",
        type=T.float_in(10.0, 170.0, unit="degrees"),
        default=photo.hfov_deg,
        help=f"the photos' horizontal field of view in degrees (default: {photo.hfov_deg:g})",
    )
    g.add_argument(
        "--pitch",
        type=T.float_in(-30.0, 60.0, unit="degrees"),
        default=photo.pitch_deg,
        help=f"the camera's pitch down in degrees (default: {photo.pitch_deg:g})",
    )
    g.add_argument(
        "--mount-height",
        type=T.float_in(0.2, 10.0, unit="m"),
        default=photo.mount_height_m,
        help=f"the camera's height above the road in m (default: {photo.mount_height_m:g})",
    )
    g.add_argument(
        "--plot", type=T.output_file(figure_suffixes), help="write the retained-IoU plot (per weather) to this PNG"
    )
    add_camera_profile(p)
    p.set_defaults(func=commands.cmd_evaluate)

    d = {k: default_of(filter_effect_table, k) for k in ("severity", "noises", "seeds", "frames")}
    variant = default_of(apply_filters, "variant")
    p = _command(
        sub,
        "filter-effect",
        description="Render held-out worlds of every scenario under each noise and score the shipped detector without filters and with the filter meant for that noise (shadow -> shadow, rain and snow -> rain_snow, glare -> light), then with all filters; FNR and FPR pooled over the ground pixels, and the difference of FNR + FPR (with - without, points) with its 95 % interval from a bootstrap of the episodes in pairs.",
    )
    p.add_argument(
        "--severity",
        type=T.float_list(0.0, 1.0),
        default=_shown(d["severity"]),
        help=f"comma-separated severities in [0, 1] (default: {d['severity']})",
    )
    p.add_argument(
        "--noises",
        type=T.choice_list(tuple(d["noises"])),
        default=_shown(d["noises"]),
        help=f"comma-separated noises (default: {_shown(d['noises'])})",
    )
    p.add_argument(
        "--variant",
        type=T.choice_list(FILTER_VARIANTS),
        default=variant,
        help=f"comma-separated filter variants: {names(FILTER_VARIANTS)} (default: {variant})",
    )
    _add_held_out_seeds(p, d["seeds"])
    p.add_argument(
        "--frames", type=_COUNT, default=d["frames"], help=f"frames per scenario and seed (default: {d['frames']})"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    add_camera_profile(p)
    p.set_defaults(func=commands.cmd_filter_effect)


def _add_pictures(sub: Any) -> None:
    p = _command(
        sub,
        "figure",
        description="Draw the README pictures: 'camera' (clean frame, GT outline, BEV), 'weather' (the noise gallery), 'places' (the same places clean and in low sun), 'friction' (braking distance and cornering speed vs weather) or 'windscreen' (drops on the glass and a wiper pass).",
    )
    p.add_argument("what", choices=("camera", "weather", "places", "friction", "windscreen"), help="which figure")
    p.add_argument("--out", type=T.output_file(figure_suffixes), required=True, help="output PNG path")
    seed = default_of(camera_figure, "seed")
    p.add_argument(
        "--seed", type=T.int_in(0, T.MAX_SEED - len(SCENARIO_NAMES)), default=seed, help=f"seed (default: {seed})"
    )
    add_camera_profile(p)
    p.set_defaults(func=commands.cmd_figure)


def build_parser() -> argparse.ArgumentParser:
    """The ``simroad`` argument parser with every subcommand."""
    parser, sub = command_parser(T.GivenParser)
    for add in (
        _add_frames,
        _add_episode,
        _add_ablate,
        _add_detector,
        _add_pictures,
        add_videos,
        add_realism,
        add_calibrate,
    ):
        add(sub)
    return parser
