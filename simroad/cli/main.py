"""The ``simroad`` command line: argument parsing only; the library does the work.

Exit status: 0 on success, 2 on bad input (with a message saying what to fix),
1 when a requirement (``--require``) is violated.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from simroad._validation import SimroadError

__all__ = ["build_parser", "main"]


def _add_env_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("environment")
    g.add_argument("--scenario", default="racetrack", help="racetrack, highway or winding (default: racetrack)")
    g.add_argument(
        "--noise", default="clear", help="clear, rain, snow, shadow, glare, fog, or a composition like rain+glare"
    )
    g.add_argument("--severity", type=float, default=0.5, help="weather severity in [0, 1] (default: 0.5)")
    g.add_argument("--width", type=int, default=320, help="image width in pixels, 16-1280 (default: 320)")
    g.add_argument("--height", type=int, default=180, help="image height in pixels, 16-720 (default: 180)")
    g.add_argument("--hfov", type=float, default=70.0, help="horizontal field of view in degrees, 30-120 (default: 70)")
    g.add_argument("--pitch", type=float, default=5.0, help="camera pitch down in degrees, 0-30 (default: 5)")
    g.add_argument("--no-traffic", action="store_true", help="no other vehicles")


def _env_kwargs(args: argparse.Namespace) -> dict:
    return {
        "scenario": args.scenario,
        "noise": args.noise,
        "severity": args.severity,
        "width": args.width,
        "height": args.height,
        "hfov_deg": args.hfov,
        "pitch_deg": args.pitch,
        "traffic": not args.no_traffic,
    }


def _cmd_frames(args: argparse.Namespace) -> int:
    from simroad.experiments.export import export_frames

    out = export_frames(
        args.out,
        seed=args.seed,
        count=args.count,
        every=args.every,
        env_kwargs=_env_kwargs(args),
        progress=not args.quiet,
    )
    print(f"wrote {args.count} frames, road masks and meta.json to {out}")
    return 0


def _cmd_episode(args: argparse.Namespace) -> int:
    import json

    from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, run_episode
    from simroad.experiments.gate import check_requirements, parse_requirement

    requirements = [parse_requirement(r, valid_keys=RECORD_KEYS) for r in args.require]
    spec = EpisodeSpec(
        scenario=args.scenario, noise=args.noise, severity=args.severity, filters=args.filters,
        driver=args.driver, seed=args.seed, steps=args.steps, traffic=not args.no_traffic,
        route_m=args.route_m, env_options={"width": args.width, "height": args.height, "hfov_deg": args.hfov, "pitch_deg": args.pitch},
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


def _cmd_ablate(args: argparse.Namespace) -> int:
    from simroad.experiments.ablate import run_ablation
    from simroad.experiments.grid import AblationGrid, load_grid_file
    from simroad.experiments.report import build_report

    opts = load_grid_file(args.config) if args.config else {}
    for key in (
        "scenarios",
        "noises",
        "severities",
        "filters",
        "seeds",
        "seed_start",
        "steps",
        "workers",
        "backend",
        "ray_address",
        "out",
    ):
        value = getattr(args, key)
        if value is not None:
            opts[key] = value
    run = {k: opts.pop(k) for k in ("workers", "backend", "ray_address", "out") if k in opts}
    if "out" not in run:
        print("simroad ablate: error: --out is required (or 'out' in the --config file)", file=sys.stderr)
        return 2
    grid = AblationGrid(**opts)
    records = run_ablation(
        grid,
        run["out"],
        workers=run.get("workers"),
        backend=run.get("backend", "local"),
        ray_address=run.get("ray_address"),
        fresh=args.fresh,
        progress=not args.quiet,
    )
    paths = build_report(run["out"])
    failed = sum(1 for r in records if r.get("error"))
    print(
        f"{len(records)} episodes in {run['out']}/results.jsonl ({failed} failed); report: "
        + ", ".join(str(p) for p in paths.values())
    )
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from simroad.experiments.report import build_report

    paths = build_report(args.dir)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


def _cmd_train(args: argparse.Namespace) -> int:
    from simroad.experiments.training import train_detector

    seeds = range(args.seed_start, args.seed_start + args.seeds)
    path = train_detector(args.out, seeds=seeds, frames_per_seed=args.frames)
    print(f"wrote {path}")
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    import json

    from simroad.experiments.episode import parse_filters
    from simroad.experiments.evaluate import evaluate_frames, format_table, load_image_folder, qualitative_figure
    from simroad.experiments.frames import collect_frames

    settings = [parse_filters(f) for f in args.filters.split(",")]
    if args.images or args.masks:
        if not (args.images and args.masks):
            raise SimroadError("images: --images and --masks go together.")
        frames = load_image_folder(args.images, args.masks)
    else:
        seeds = range(args.seed_start, args.seed_start + args.seeds)
        frames = collect_frames(
            scenarios=args.scenario.split(","),
            seeds=seeds,
            frames_per_seed=args.frames,
            noise=args.noise,
            severity=args.severity,
        )
    factory = None
    if args.model:
        from simroad.detector import RoadDetector

        base = RoadDetector.load(args.model)
        factory = lambda f: RoadDetector.load(args.model).set_params(filters=f) if f != tuple(base.filters) else base  # noqa: E731
    rows, frows = evaluate_frames(frames, settings, detector_factory=factory)
    if args.json:
        print(json.dumps({"detector": rows, "filter_masks": frows}))
    else:
        print(format_table(rows, percent=("fnr", "fpr")))
        if frows:
            print()
            print(format_table(frows))
    if args.figure:
        print(f"wrote {qualitative_figure(args.figure)}")
    return 0


def _cmd_filter_effect(args: argparse.Namespace) -> int:
    import json

    from simroad.detector import RoadDetector
    from simroad.experiments.filter_effect import filter_effect_table, format_filter_effect

    seeds = range(args.seed_start, args.seed_start + args.seeds)
    cache: dict = {}
    out = []
    for severity in (float(s) for s in args.severity.split(",")):
        for variant in args.variant.split(","):
            factory = lambda f, v=variant: RoadDetector.pretrained(filters=f, filter_variant=v)  # noqa: E731
            rows = filter_effect_table(seeds=seeds, frames=args.frames, severity=severity, noises=args.noises.split(","),
                                       detector_factory=factory, cache=cache)  # fmt: skip
            out.append({"severity": severity, "variant": variant, "rows": rows})
            if not args.json:
                print(f"severity {severity:g}, {variant} filters")
                print(format_filter_effect(rows))
                print()
    if args.json:
        print(json.dumps(out, default=list))
    return 0


def _cmd_figure(args: argparse.Namespace) -> int:
    from simroad.experiments import figures

    if args.what == "camera":
        path = figures.camera_figure(args.out, seed=args.seed)
    else:
        from simroad.noise.gallery import render_gallery

        path = render_gallery(args.out, seed=args.seed)
    print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="simroad", description="Closed-loop camera road detection testbed in bad weather."
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser(
        "frames",
        help="export camera frames and ground-truth road masks",
        description="Drive the ground-truth autopilot and write frame_NNNN.png, road_NNNN.png (GT 0/255) and meta.json (camera intrinsics, pose per frame).",
    )
    _add_env_options(p)
    p.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    p.add_argument("--count", type=int, default=50, help="number of frames (default: 50)")
    p.add_argument("--every", type=int, default=1, help="policy steps between frames (default: 1)")
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_frames)

    p = sub.add_parser(
        "episode",
        help="run one closed-loop episode and score it",
        description="Drive one episode: the camera frame goes to the driver (the road detector + lane keeping, or the oracle on the ground-truth mask); the episode is scored on the mask (FNR/FPR) and on safety. Exit status 1 if a --require fails.",
    )
    _add_env_options(p)
    p.add_argument(
        "--filters",
        default="none",
        help="detector filters: none, all, or names joined by '+' (shadow, rain_snow, light), e.g. shadow+light",
    )
    p.add_argument("--driver", default="detector", help="detector (default) or oracle")
    p.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    p.add_argument("--steps", type=int, default=300, help="maximum policy steps at 5 Hz (default: 300)")
    p.add_argument(
        "--route-m",
        type=float,
        default=None,
        help="route length in m (default: one racetrack lap or 1 km, capped at 80%% of cruise speed x steps x 0.2 s)",
    )
    p.add_argument("--video", default=None, help="write an .mp4 or .gif of the episode")
    p.add_argument("--json", action="store_true", help="print one JSON object with the record")
    p.add_argument(
        "--require",
        action="append",
        default=[],
        metavar="KEY<=VALUE",
        help="a gate such as 'offroad_fraction<=0.01' (any record key; <, <=, >, >=); repeatable",
    )
    p.set_defaults(func=_cmd_episode)

    p = sub.add_parser(
        "ablate",
        help="run an ablation sweep (resumable) and write its report",
        description="Run scenarios x noises x severities x filter sets x seeds, plus one oracle episode per scenario x noise x severity x seed; results are appended to OUT/results.jsonl as each episode finishes (rerun to resume), then summary.csv, summary.md, error_rates.png and safety.png are written.",
    )
    p.add_argument("--config", help="a TOML file with the same names as keys (flags override it)")
    p.add_argument("--scenarios", help="comma-separated, e.g. racetrack,winding")
    p.add_argument("--noises", help="comma-separated, e.g. clear,rain,snow,shadow,glare or rain+glare")
    p.add_argument("--severities", help="comma-separated values in [0, 1], e.g. 0.4,0.8")
    p.add_argument(
        "--filters", help="comma-separated filter sets: none, all, shadow, rain_snow, light, shadow+light, ..."
    )
    p.add_argument("--seeds", type=int, help="number of seeds (default 3)")
    p.add_argument("--seed-start", dest="seed_start", type=int, help="first seed (default 0)")
    p.add_argument("--steps", type=int, help="policy steps per episode (default 150)")
    p.add_argument("--workers", type=int, help="parallel episodes (default: all cores)")
    p.add_argument("--backend", help="local (process pool, default) or ray")
    p.add_argument("--ray-address", dest="ray_address", help="Ray cluster address (with --backend ray)")
    p.add_argument("--out", help="output directory")
    p.add_argument("--fresh", action="store_true", help="delete results of a different grid in --out and start anew")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_ablate)

    p = sub.add_parser("report", help="rebuild a sweep's tables and figures from results.jsonl")
    p.add_argument("dir", help="the sweep's output directory")
    p.set_defaults(func=_cmd_report)

    p = sub.add_parser(
        "train-detector",
        help="reproduce the shipped road detector",
        description="Render clean frames of all three scenarios (one world palette per seed), fit the default SVM detector and save it as npz (no pickle).",
    )
    p.add_argument("--out", default=None, help="output .npz (default: the package's shipped model file)")
    p.add_argument("--seeds", type=int, default=16, help="number of training worlds (default: 16)")
    p.add_argument("--seed-start", type=int, default=0, help="first seed (default: 0; evaluation uses seeds >= 100)")
    p.add_argument("--frames", type=int, default=12, help="frames per scenario and seed (default: 12)")
    p.set_defaults(func=_cmd_train)

    p = sub.add_parser(
        "evaluate-detector",
        help="score the detector per filter setting (FNR, FPR, IoU, F1)",
        description="Score the shipped detector on rendered frames (held-out seeds) or on a folder of real images and masks, for each filter setting; also score the filters' own masks against the ground-truth noise masks.",
    )
    p.add_argument(
        "--scenario", default="racetrack,highway,winding", help="comma-separated scenarios (default: all three)"
    )
    p.add_argument("--noise", default="clear", help="weather of the rendered frames")
    p.add_argument("--severity", type=float, default=0.7, help="weather severity in [0, 1] (default: 0.7)")
    p.add_argument("--filters", default="none,all", help="comma-separated filter settings (default: none,all)")
    p.add_argument("--seeds", type=int, default=5, help="number of held-out seeds (default: 5)")
    p.add_argument("--seed-start", type=int, default=100, help="first seed (default: 100)")
    p.add_argument("--frames", type=int, default=20, help="frames per scenario and seed (default: 20)")
    p.add_argument("--images", help="folder of real images (instead of rendered frames)")
    p.add_argument("--masks", help="folder of their road masks (same file names, or road_N for frame_N)")
    p.add_argument("--model", help="a detector .npz to evaluate instead of the shipped one")
    p.add_argument("--figure", help="also draw the paper's qualitative figure (Figs. 3-6) to this PNG")
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.set_defaults(func=_cmd_evaluate)

    p = sub.add_parser(
        "filter-effect",
        help="does each filter earn its place? FNR/FPR with and without it on its weather",
        description="Render held-out worlds of all three scenarios under each noise and score the shipped detector without filters and with the filter meant for that noise (shadow -> shadow, rain and snow -> rain_snow, glare -> light), then with all filters; FNR and FPR pooled over the ground pixels.",
    )
    p.add_argument("--severity", default="0.7", help="comma-separated severities in [0, 1] (default: 0.7)")
    p.add_argument("--noises", default="shadow,rain,snow,glare", help="comma-separated noises (default: all four)")
    p.add_argument(
        "--variant", default="improved", help="comma-separated filter variants: improved, paper (default: improved)"
    )
    p.add_argument("--seeds", type=int, default=5, help="number of held-out seeds (default: 5)")
    p.add_argument("--seed-start", type=int, default=100, help="first seed (default: 100)")
    p.add_argument("--frames", type=int, default=20, help="frames per scenario and seed (default: 20)")
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.set_defaults(func=_cmd_filter_effect)

    p = sub.add_parser(
        "figure",
        help="draw a documentation figure",
        description="Draw the README pictures: 'camera' (clean frame, GT outline, BEV) or 'weather' (the noise gallery).",
    )
    p.add_argument("what", choices=("camera", "weather"), help="which figure")
    p.add_argument("--out", required=True, help="output PNG path")
    p.add_argument("--seed", type=int, default=0, help="seed (default: 0)")
    p.set_defaults(func=_cmd_figure)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except SimroadError as exc:
        print(f"simroad {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
