"""``simroad realism``: its options and its run (appearance statistics of rendered
frames against real photographs, :mod:`simroad.experiments.realism`)."""

from __future__ import annotations

import argparse
from typing import Any

from simroad.cli import types as T
from simroad.cli.commands import seed_range
from simroad.cli.env_options import MASK_FORMATS, add_camera_profile, add_mask_format, add_worlds, default_of
from simroad.cli.index import COMMANDS
from simroad.errors import InvalidParameterError
from simroad.experiments.realism import (
    format_realism_table,
    photo_reference,
    realism_report,
    write_realism,
)
from simroad.metrics.appearance import MIN_ROAD_PIXELS, STATISTICS

__all__ = ["add_realism", "cmd_realism"]

DEFAULT_OUT = "runs/realism"


def add_realism(sub: Any) -> None:
    """Add ``simroad realism`` to the subcommand group ``sub``."""
    d = {k: default_of(realism_report, k) for k in ("scenarios", "seeds", "frames", "every")}
    p = sub.add_parser(
        "realism",
        help=COMMANDS["realism"],
        description="How real do the rendered frames look? Render clear frames of held-out worlds (the camera's "
        "sensor on, as in every env by default), compute per frame "
        f"{', '.join(STATISTICS)} (see simroad.metrics.appearance) and print, per statistic, p10 / median / p90 "
        "of the real photographs beside the frames' (pooled over the scenarios) and the Kolmogorov-Smirnov "
        "distance to the photographs (0: the same distribution, 1: no overlap), pooled and per scenario. The "
        "reference is the shipped table of 701 CamVid photographs, or --reference, or your own --photos with "
        "--masks. Writes OUT/realism.csv (one row per frame: scenario, seed, step, the statistics), "
        "OUT/realism.json (the table) and OUT/realism.png (the CDFs). The exit status is 0 whatever the "
        "distances; 2 on bad input.",
    )
    add_worlds(
        p, d, max_seeds=100_000, max_frames=1000,
        seeds_help="number of worlds (default: {n}, the worlds {first}-{last}, which no tuning has used)",
        frames_help="frames per scenario and seed",
    )  # fmt: skip
    p.add_argument(
        "--every",
        type=T.int_in(1, 1000),
        default=d["every"],
        help=f"policy steps between frames; the first is this many steps in (default: {d['every']})",
    )
    p.add_argument(
        "--out",
        type=T.output_dir(),
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"output directory (default: {DEFAULT_OUT})",
    )
    g = p.add_argument_group("reference (default: the shipped CamVid table)")
    g.add_argument(
        "--reference",
        type=T.input_file(),
        metavar="CSV",
        help="a quantile table CSV: '#' comment lines, the header statistic,q00,q05,...,q100 and one row per "
        "statistic (the layout of simroad/data/road_photos_appearance.csv)",
    )
    g.add_argument(
        "--photos",
        type=T.input_dir(),
        metavar="DIR",
        help="your own road photographs (PNG, JPEG, ...); the reference is their statistics' quantiles",
    )
    g.add_argument(
        "--masks",
        type=T.input_dir(),
        metavar="DIR",
        help=f"with --photos: their road masks, same file names: {MASK_FORMATS}; photos with fewer "
        f"than {MIN_ROAD_PIXELS} road pixels are left out",
    )
    add_mask_format(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_camera_profile(p)
    p.set_defaults(func=cmd_realism)


def cmd_realism(args: argparse.Namespace) -> int:
    """``simroad realism``: the report, its table on stdout and its files in ``--out``."""
    if (args.photos is None) != (args.masks is None):
        raise InvalidParameterError(
            "--photos/--masks: give both folders (the photographs and their road masks), or neither."
        )
    if args.photos is not None and args.reference is not None:
        raise InvalidParameterError(
            "--reference: a reference comes from a table file or from --photos/--masks, not both; drop one."
        )
    if args.photos is None and (args.road_value is not None or args.road_colour is not None):
        raise InvalidParameterError("--road-value/--road-colour: read the masks of --photos/--masks; give those too.")
    reference = (
        photo_reference(args.photos, args.masks, road_value=args.road_value, road_colour=args.road_colour)
        if args.photos is not None
        else args.reference
    )
    report = realism_report(
        scenarios=args.scenarios,
        seeds=seed_range(args.seed_start, args.seeds),
        frames=args.frames,
        every=args.every,
        reference=reference,
        env_options={} if args.camera_profile is None else {"camera_profile": args.camera_profile},
        progress=not args.quiet,
    )
    print(format_realism_table(report))
    paths = write_realism(report, args.out)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
