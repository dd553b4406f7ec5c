"""``simroad videos``: one short captioned episode per weather as an annotated GIF, with the
detector and filters of your choice."""

from __future__ import annotations

import argparse
from typing import Any

from simroad.cli import types as T
from simroad.cli.env_options import add_camera_profile, add_detector_flags, default_of, names
from simroad.cli.index import COMMANDS
from simroad.detector.registry import parse_detector_options
from simroad.envs.scenarios import SCENARIO_NAMES
from simroad.experiments.demo import write_videos

__all__ = ["add_videos", "cmd_videos"]


def add_videos(sub: Any) -> None:
    """The ``videos`` subcommand."""
    d = {k: default_of(write_videos, k) for k in ("scenario", "seed", "steps", "severity", "filters")}
    p = sub.add_parser(
        "videos",
        help=COMMANDS["videos"],
        description="Drive one short episode per noise with the detector (and filters) of your choice and write "
        "OUT/NOISE.gif: the camera view with the predicted road mask (green), the ground-truth outline (yellow), "
        "a bird's-eye inset with the trajectory and a caption saying the world, the weather and what drove.",
    )
    p.add_argument("--out", type=T.output_dir(), required=True, help="output directory (created)")
    p.add_argument(
        "--scenario",
        type=T.choice(SCENARIO_NAMES),
        default=d["scenario"],
        help=f"{names(SCENARIO_NAMES)} (default: {d['scenario']})",
    )
    p.add_argument("--seed", type=T.seed(), default=d["seed"], help=f"episode seed (default: {d['seed']})")
    p.add_argument(
        "--steps",
        type=T.int_in(1, 1_000_000),
        default=d["steps"],
        help=f"policy steps per video (default: {d['steps']})",
    )
    p.add_argument(
        "--severity",
        type=T.float_in(0.0, 1.0),
        default=d["severity"],
        help=f"weather severity in [0, 1] (default: {d['severity']})",
    )
    p.add_argument(
        "--filters",
        type=T.filter_set(),
        default=d["filters"],
        help=f"the filters in front of the detector: none, all, or names joined by + (default: {d['filters']})",
    )
    p.add_argument(
        "--compare",
        type=_compare,
        default="none",
        help="filters of a second view left of the driving one, on the same frames (it does not drive): "
        "none, all, names joined by +, or off for one view (default: none, i.e. without and with filters)",
    )
    add_detector_flags(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_camera_profile(p)
    p.set_defaults(func=cmd_videos)


def _compare(value: str) -> str:
    """``--compare``: a filter set, or ``off``."""
    if value == "off":
        return value
    try:
        return T.filter_set()(value)
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"{exc} Or 'off' for one view.") from None


def cmd_videos(args: argparse.Namespace) -> int:
    """``simroad videos``: one annotated GIF per noise."""
    paths = write_videos(
        args.out,
        scenario=args.scenario,
        seed=args.seed,
        steps=args.steps,
        severity=args.severity,
        filters=args.filters,
        detector=args.detector,
        detector_options=parse_detector_options(args.detector_option),
        progress=not args.quiet,
        camera_profile=args.camera_profile,
        compare=None if args.compare == "off" else args.compare,
    )
    print("videos: " + ", ".join(str(p) for p in paths))
    return 0
