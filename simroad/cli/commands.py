"""Run each ``simroad`` subcommand: parsed arguments in, one library call, text out.

Each ``cmd_*`` takes the :class:`argparse.Namespace` of its subcommand (see
:mod:`simroad.cli.parser`), builds the library's config objects, calls the library
and prints the outcome; it returns the exit status.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
from pathlib import Path
from typing import Any

from simroad.cli.env_options import env_options, given_camera_options
from simroad.cli.types import MAX_SEED, given
from simroad.core.validation import check_choice, check_output_dir
from simroad.detector import RoadDetector
from simroad.detector.registry import parse_detector_options
from simroad.errors import InvalidParameterError
from simroad.experiments.ablate import BACKENDS, run_ablation
from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, run_episode
from simroad.experiments.evaluate import (
    FIGURE_NOISES,
    detector_factory,
    evaluate_detector,
    format_table,
    qualitative_figure,
)
from simroad.experiments.export import export_frames
from simroad.experiments.figures import camera_figure, places_figure
from simroad.experiments.filter_effect import filter_effect_table, format_filter_effect
from simroad.experiments.friction_figure import friction_figure
from simroad.experiments.gallery import render_gallery, render_wiper_sequence
from simroad.experiments.gate import check_requirements, parse_requirement
from simroad.experiments.grid import AblationGrid, load_grid_file
from simroad.experiments.photos import load_image_folder
from simroad.experiments.report import build_report, failed_components
from simroad.experiments.robustness import PhotoCamera, fit_to_camera, robustness, robustness_figure
from simroad.experiments.training import train_detector
from simroad.filters.pipeline import parse_filters

__all__ = [
    "ABLATE_GRID_FLAGS",
    "RUN_KEYS",
    "cmd_ablate",
    "cmd_episode",
    "cmd_evaluate",
    "cmd_figure",
    "cmd_filter_effect",
    "cmd_frames",
    "cmd_report",
    "cmd_train",
    "refuse_flags",
    "seed_range",
]

#: ``simroad ablate`` flags that set AblationGrid fields (None: not given).
ABLATE_GRID_FLAGS = ("scenarios", "noises", "severities", "filters", "detectors", "seeds", "seed_start", "steps")
#: Keys of ``simroad ablate`` that configure the run, not the grid.
RUN_KEYS = ("workers", "backend", "ray_address", "out")


def seed_range(start: int, count: int) -> range:
    """``count`` seeds from ``start`` (the last one must still be a valid seed)."""
    if start + count - 1 > MAX_SEED:
        raise InvalidParameterError(
            f"--seed-start/--seeds: the seeds {start}..{start + count - 1} pass the largest seed {MAX_SEED}; "
            "lower --seed-start or --seeds."
        )
    return range(start, start + count)


def refuse_flags(args: argparse.Namespace, dests: tuple[str, ...], mode: str) -> None:
    """Refuse options the user gave that do not apply in ``mode`` (exit status 2)."""
    bad = [d for d in dests if d in given(args)]
    if bad:
        flags = ", ".join("--" + d.replace("_", "-") for d in bad)
        raise InvalidParameterError(
            f"{flags}: {'does' if len(bad) == 1 else 'do'} not apply {mode} and would be ignored; drop "
            f"{'it' if len(bad) == 1 else 'them'}."
        )


def cmd_frames(args: argparse.Namespace) -> int:
    """``simroad frames``: export frames, GT road masks and meta.json."""
    env_kwargs = {"scenario": args.scenario, "noise": args.noise, "severity": args.severity,
                  **env_options(args), "traffic": not args.no_traffic}  # fmt: skip
    out = export_frames(
        args.out, seed=args.seed, count=args.count, every=args.every, env_kwargs=env_kwargs, progress=not args.quiet
    )
    print(f"wrote {args.count} frames, road masks and meta.json to {out}")
    return 0


def cmd_episode(args: argparse.Namespace) -> int:
    """``simroad episode``: run one episode, print its record, check ``--require`` gates."""
    gated = [k for k in RECORD_KEYS if k not in ("camera_profile", "detector_options", "env_options")]  # tables
    requirements = [parse_requirement(r, valid_keys=gated) for r in args.require]
    if args.driver == "oracle" and parse_filters(args.filters):
        refuse_flags(args, ("filters",), "with --driver oracle (it drives on the ground-truth mask, no detector)")
    if args.driver == "oracle" and (args.detector != "paper" or args.detector_option):
        raise InvalidParameterError(
            "--detector/--detector-option: not used with --driver oracle (it drives on the ground-truth mask); "
            "drop them or use --driver detector."
        )
    spec = EpisodeSpec(
        scenario=args.scenario, noise=args.noise, severity=args.severity, filters=args.filters,
        driver=args.driver, seed=args.seed, steps=args.steps, traffic=not args.no_traffic,
        route_m=args.route_m, env_options=env_options(args), detector=args.detector,
        detector_options=parse_detector_options(args.detector_option),
    )  # fmt: skip
    record = run_episode(spec, video=args.video)
    if args.json:
        print(json.dumps(record))
    else:
        for key in RECORD_KEYS:
            value = record[key]
            print(f"{key:>18}: {value:.4g}" if isinstance(value, float) else f"{key:>18}: {value}")
    failures = check_requirements(record, requirements)
    for msg in failures:
        print(f"simroad episode: {msg}", file=sys.stderr)
    return 1 if failures else 0


def _detector_option_flags(items: list[str], detectors: Any, options: dict) -> dict:
    """``--detector-option SPEC@KEY=VALUE`` (or ``KEY=VALUE`` with one detector besides
    paper) merged over the TOML file's options."""
    specs = [d.strip() for d in (detectors.split(",") if isinstance(detectors, str) else detectors)]
    own = [d for d in specs if d != "paper"]
    for item in items:
        spec, at, pair = item.rpartition("@")
        if not at:
            if len(own) != 1:
                raise InvalidParameterError(
                    f"--detector-option: {item!r} does not say which detector it is for; write SPEC@KEY=VALUE "
                    f"with SPEC one of {specs}."
                )
            spec = own[0]
        options.setdefault(spec, {}).update(parse_detector_options([pair]))
    return options


def cmd_ablate(args: argparse.Namespace) -> int:
    """``simroad ablate``: run (or resume) a sweep from flags and/or ``--config``, then its report."""
    opts = load_grid_file(args.config) if args.config else {}
    for key in (*ABLATE_GRID_FLAGS, *RUN_KEYS):
        value = getattr(args, key)
        if value is not None:
            opts[key] = value
    if args.no_friction:
        opts["friction"] = False
    if args.detector_option:
        opts["detector_options"] = _detector_option_flags(
            args.detector_option, opts.get("detectors", ("paper",)), dict(opts.get("detector_options", {}))
        )
    camera = given_camera_options(args)
    if camera:
        opts["env_options"] = {**opts.get("env_options", {}), **camera}
    run = {k: opts.pop(k) for k in RUN_KEYS if k in opts}
    if args.camera_profile is not None:
        opts["camera_profile"] = args.camera_profile
    if "out" not in run:
        print("simroad ablate: error: --out is required (or 'out' in the --config file)", file=sys.stderr)
        return 2
    out = run.pop("out")
    check_output_dir("out", out)
    if "backend" in run:
        check_choice("backend", run["backend"], BACKENDS)
    if "ray_address" in run and run.get("backend", "local") != "ray":
        raise InvalidParameterError(
            "--ray-address (ray_address): does not apply with the local backend; add --backend ray (backend = "
            '"ray" in the config) to join a Ray cluster, or drop it.'
        )
    if "ray_address" in run and "workers" in run:
        raise InvalidParameterError(
            "--workers (workers): does not apply with --ray-address (the cluster's CPUs run the episodes); drop it."
        )
    grid = AblationGrid(**opts)
    try:
        records = run_ablation(grid, out, **run, fresh=args.fresh, progress=not args.quiet)
    except KeyboardInterrupt:
        with contextlib.suppress(ValueError):  # (not the main thread: nothing to do)
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # the sweep has stopped: let the exit (130) finish
        raise
    paths = build_report(out)
    failed = sum(1 for r in records if r.get("error"))
    print(
        f"{len(records)} episodes in {out}/results.jsonl ({failed} failed); report: "
        + ", ".join(str(p) for p in paths.values())
    )
    for f in failed_components(records):
        print(f"simroad ablate: {f['driver']} (filters {f['filters']}): {f['failed']} of {f['episodes']} episodes "
              f"failed, first: {f['error']} (all in {paths['summary.md']})", file=sys.stderr)  # fmt: skip
    return 3 if failed else 0


def cmd_report(args: argparse.Namespace) -> int:
    """``simroad report``: rebuild a sweep's tables and figures."""
    paths = build_report(*args.dir, out=args.out)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    """``simroad train-detector``: train a detector and write it to ``--out``."""
    path = train_detector(
        args.out,
        seeds=seed_range(args.seed_start, args.seeds),
        frames_per_seed=args.frames,
        camera_profile=args.camera_profile,
    )
    print(f"wrote {path}; use it with RoadDetector.load({str(path)!r}) or --model {path}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    """``simroad evaluate-detector``: score filter settings on frames; optional figure;
    with ``--images`` and a ``--noise``, the robustness to weather on the photos."""
    if isinstance(args.noise, str):  # as typed: comma-separated weather specs
        args.noise = [n.strip() for n in args.noise.split(",") if n.strip()]
    args.severity = list(args.severity)
    photos = args.images is not None or args.masks is not None
    if photos:
        if args.images is None or args.masks is None:
            raise InvalidParameterError(
                "--images/--masks: give both folders (images and their road masks), or neither."
            )
        refuse_flags(args, ("scenario", "seeds", "seed_start", "frames", "camera_profile"),
                     "with --images (the frames are read from the folder, not rendered)")  # fmt: skip
    else:
        refuse_flags(args, ("weather_seed", "hfov", "pitch", "mount_height", "plot"),
                     "without --images (they set the weather on photographs)")  # fmt: skip
        refuse_flags(args, ("road_value", "road_colour"), "without --images (they read the masks of photographs)")
        if len(args.noise) != 1 or len(args.severity) != 1:
            raise InvalidParameterError(
                "--noise/--severity: rendered frames have one weather and one severity; lists are for --images."
            )
    if photos and args.noise != ["clear"]:
        return _evaluate_photos(args)
    if photos and "severity" in given(args):
        refuse_flags(args, ("severity",), "with --images and no --noise (clean photos have no severity)")
    if photos:
        refuse_flags(args, ("weather_seed", "hfov", "pitch", "mount_height", "plot"),
                     "with --images and no --noise (no weather is put on the photos)")  # fmt: skip
    seeds = seed_range(args.seed_start, args.seeds)
    rows, frows = evaluate_detector(
        [f.strip() for f in args.filters.split(",") if f.strip()],
        scenarios=args.scenario,
        noise=args.noise[0],
        severity=args.severity[0],
        seeds=seeds,
        frames_per_seed=args.frames,
        images=args.images or None,
        masks=args.masks or None,
        road_value=args.road_value,
        road_colour=args.road_colour,
        model=args.model,
        detector=args.detector,
        detector_options=parse_detector_options(args.detector_option),
        camera_profile=args.camera_profile,
    )
    frames = rows[0]["frames"] if rows else 0
    if args.images:
        source = f"{frames} images of {args.images}"
    else:
        worlds = f"world {seeds[0]}" if len(seeds) == 1 else f"worlds {seeds[0]}-{seeds[-1]}"
        source = (f"{frames} rendered frames ({', '.join(args.scenario)}; {worlds}; "
                  f"{args.noise[0]}{f' {args.severity[0]:g}' if args.noise[0] != 'clear' else ''})")  # fmt: skip
    detector = {"spec": args.detector, "model": args.model, "options": parse_detector_options(args.detector_option)}
    if args.json:
        print(json.dumps({"detector": detector, "source": source, "rows": rows, "filter_masks": frows}))
    else:
        model = f", model {args.model}" if args.model else ""
        print(f"detector {args.detector}{model} on {source}")
        print(format_table(rows, percent=("fnr", "fpr", "fnr_image", "fpr_image")))
        if frows:
            print()
            print(format_table(frows))
    if args.figure:
        print(f"wrote {_figure(args, seeds[0])}")
    return 0


def _figure(args: argparse.Namespace, seed: int) -> Any:
    """``evaluate-detector --figure``: the chosen detector, filter settings, scenarios
    and weather (without --noise: the paper's four weathers; without --scenario: winding)."""
    noise, severity = args.noise[0], args.severity[0]
    factory = detector_factory(args.model, args.detector, parse_detector_options(args.detector_option))
    return qualitative_figure(
        args.figure,
        scenarios=args.scenario if "scenario" in given(args) else ("winding",),
        seed=seed,  # a held-out world, as scored
        noises=FIGURE_NOISES if noise == "clear" else (noise,),
        severity=severity,
        settings=[parse_filters(f) for f in args.filters.split(",") if f.strip()],
        detector_factory=factory,
        detector_name=args.detector if args.model is None else f"{args.detector} ({args.model})",
    )


def _evaluate_photos(args: argparse.Namespace) -> int:
    """The weather on the user's photos: a robustness table per noise and severity."""

    if args.figure:
        raise InvalidParameterError(
            "--figure: draws rendered frames of every weather; it does not apply with --images."
        )
    noises = [n for n in args.noise if n != "clear"]
    factory = detector_factory(args.model, args.detector, parse_detector_options(args.detector_option))
    frames = fit_to_camera(
        load_image_folder(args.images, args.masks, road_value=args.road_value, road_colour=args.road_colour)
    )
    mount = PhotoCamera(hfov_deg=args.hfov, pitch_deg=args.pitch, mount_height_m=args.mount_height)
    settings = [parse_filters(f) for f in args.filters.split(",") if f.strip()]
    rows, summary = robustness(frames, settings, noises, args.severity, factory, seed=args.weather_seed, mount=mount)
    if args.json:
        print(json.dumps({"robustness": rows, "summary": summary}))
    else:
        print(format_table(rows, percent=("fnr", "fpr")))
        print()
        print(format_table(summary))
    if args.plot:
        print(f"wrote {robustness_figure(rows, args.plot)}")
    return 0


def cmd_filter_effect(args: argparse.Namespace) -> int:
    """``simroad filter-effect``: each filter with and without on its weather."""

    seeds = seed_range(args.seed_start, args.seeds)
    cache: dict = {}
    out = []
    for severity in args.severity:
        for variant in args.variant:
            factory = lambda f, v=variant: RoadDetector.pretrained(filters=f, filter_variant=v)  # noqa: E731
            rows = filter_effect_table(seeds=seeds, frames=args.frames, severity=severity, noises=args.noises,
                                       detector_factory=factory, cache=cache,
                                       camera_profile=args.camera_profile)  # fmt: skip
            out.append({"severity": severity, "variant": variant, "rows": rows})
            if not args.json:
                print(f"severity {severity:g}, {variant} filters")
                print(format_filter_effect(rows))
                print()
    if args.json:
        print(json.dumps(out, default=list))
    return 0


def cmd_figure(args: argparse.Namespace) -> int:
    """``simroad figure``: draw a README figure."""
    if args.what in ("weather", "windscreen") and Path(args.out).suffix.lower() != ".png":
        raise InvalidParameterError(
            f"--out: the {args.what} figure is written as PNG; give a name ending in .png, got {args.out!r}."
        )
    if args.what not in ("camera", "places"):
        refuse_flags(args, ("camera_profile",), f"to the {args.what} figure (only camera and places render with it)")
    if args.what == "camera":
        path = camera_figure(args.out, seed=args.seed, camera_profile=args.camera_profile)
    elif args.what == "places":
        path = places_figure(args.out, seed=args.seed, camera_profile=args.camera_profile)
    elif args.what == "friction":
        path = friction_figure(args.out)
    elif args.what == "windscreen":
        path = render_wiper_sequence(args.out, seed=args.seed)
    else:
        path = render_gallery(args.out, seed=args.seed)
    print(f"wrote {path}")
    return 0
