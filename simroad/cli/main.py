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
    g.add_argument("--noise", default="clear", help="clear, rain, snow, shadow, glare, fog, or a composition like rain+glare")
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

    out = export_frames(args.out, seed=args.seed, count=args.count, every=args.every, env_kwargs=_env_kwargs(args), progress=not args.quiet)
    print(f"wrote {args.count} frames, road masks and meta.json to {out}")
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
    parser = argparse.ArgumentParser(prog="simroad", description="Closed-loop camera road detection testbed in bad weather.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("frames", help="export camera frames and ground-truth road masks", description="Drive the ground-truth autopilot and write frame_NNNN.png, road_NNNN.png (GT 0/255) and meta.json (camera intrinsics, pose per frame).")
    _add_env_options(p)
    p.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    p.add_argument("--count", type=int, default=50, help="number of frames (default: 50)")
    p.add_argument("--every", type=int, default=1, help="policy steps between frames (default: 1)")
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_frames)

    p = sub.add_parser("figure", help="draw a documentation figure", description="Draw the README pictures: 'camera' (clean frame, GT outline, BEV) or 'weather' (the noise gallery).")
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
