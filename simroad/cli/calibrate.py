"""``simroad calibrate``: its options and its run (fit a camera profile to the user's
photographs, :mod:`simroad.experiments.calibrate`)."""

from __future__ import annotations

import argparse
from typing import Any

from simroad.cli import types as T
from simroad.cli.commands import seed_range
from simroad.cli.env_options import MASK_FORMATS, add_mask_format, add_worlds, default_of, names
from simroad.cli.index import COMMANDS
from simroad.experiments.calibrate import (
    calibrate_from_photos,
    calibrate_profile,
    format_calibration,
    write_calibration,
)
from simroad.experiments.profile_space import FIT_PARAMETERS, FITTABLE
from simroad.metrics.appearance import MIN_ROAD_PIXELS, STATISTICS

__all__ = ["add_calibrate", "cmd_calibrate"]


def add_calibrate(sub: Any) -> None:
    """Add ``simroad calibrate`` to the subcommand group ``sub``."""
    d = {
        k: default_of(calibrate_profile, k) for k in ("scenarios", "seeds", "frames", "max_evaluations", "max_replays")
    }
    p = sub.add_parser(
        "calibrate",
        help=COMMANDS["calibrate"],
        description="Fit a camera profile (exposure bias and spread, white balance preset and AWB strength, "
        "tone gamma, asphalt albedo scale, sky brightness range, overcast and hazy shares) to your own road "
        "photographs: simroad renders clear frames of the same worlds with each profile it tries and moves the "
        f"profile until the frames' appearance statistics ({', '.join(STATISTICS)}) have the photos' quantiles "
        "(Nelder-Mead over the profile's ranges, the camera's fields on the recorded renders, the daylight's and "
        "the asphalt's by rendering again). Writes the profile as TOML (use it with --camera-profile, "
        "gym.make(..., camera_profile=PATH) or AblationGrid(camera_profile=PATH)) and prints, per statistic, "
        "the Kolmogorov-Smirnov distance to the photos with simroad's default profile and with the fitted one. "
        "A render of the default 200 worlds takes about a minute on two cores, a camera profile tried on them "
        "a few seconds.",
    )
    p.add_argument("--photos", type=T.input_dir(), required=True, metavar="DIR", help="your road photographs")
    p.add_argument(
        "--masks",
        type=T.input_dir(),
        required=True,
        metavar="DIR",
        help=f"their road masks, same file names: {MASK_FORMATS}; photos with fewer than "
        f"{MIN_ROAD_PIXELS} road pixels are left out",
    )
    add_mask_format(p)
    p.add_argument(
        "--out", type=T.output_file(lambda: (".toml",)), required=True, metavar="TOML", help="the profile to write"
    )
    add_worlds(
        p, d, max_seeds=1000, max_frames=50,
        seeds_help="worlds per scenario rendered at every evaluation (default: {n}, the worlds {first}-{last})",
        frames_help="frames per scenario and world at every evaluation",
    )  # fmt: skip
    p.add_argument(
        "--max-evaluations",
        type=T.int_in(1, 10_000),
        default=d["max_evaluations"],
        help=f"renders of the worlds at most (default: {d['max_evaluations']})",
    )
    p.add_argument(
        "--max-replays",
        type=T.int_in(1, 100_000),
        default=d["max_replays"],
        help=f"camera profiles to score on the recorded renders at most (default: {d['max_replays']})",
    )
    p.add_argument(
        "--workers",
        type=T.int_in(1, 256),
        default=None,
        help="processes that render the worlds (default: the cores this process may use)",
    )
    p.add_argument(
        "--fit",
        type=T.choice_list(FITTABLE),
        metavar="LIST",
        default=FIT_PARAMETERS,
        help=f"comma-separated profile fields to fit, of {names(FITTABLE)} (default: {names(FIT_PARAMETERS)}); "
        "the others keep simroad's defaults",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``simroad calibrate``: fit, print the before/after table, write the TOML."""
    result = calibrate_from_photos(
        args.photos,
        args.masks,
        road_value=args.road_value,
        road_colour=args.road_colour,
        fit=tuple(args.fit),
        scenarios=args.scenarios,
        seeds=seed_range(args.seed_start, args.seeds),
        frames=args.frames,
        max_evaluations=args.max_evaluations,
        max_replays=args.max_replays,
        workers=args.workers,
        progress=not args.quiet,
    )
    print(format_calibration(result))
    print(f"wrote {write_calibration(result, args.out)}")
    return 0
