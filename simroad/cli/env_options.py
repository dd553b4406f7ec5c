"""The environment options every ``simroad`` subcommand that renders frames shares.

Weather (with the windscreen), scenario, camera, scenery, sensor and friction flags, with their defaults read from
the library (:class:`RoadCamConfig`, :class:`CameraConfig`, :class:`EpisodeSpec`), and
:func:`env_options` turning the parsed flags back into RoadCam keywords.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
from collections.abc import Callable, Sequence
from typing import Any

from simroad.camera.geometry import CameraConfig
from simroad.camera.profile import CameraProfile, load_profile
from simroad.cli import types as T
from simroad.core.names import NOISE_NAMES
from simroad.envs.config import RoadCamConfig
from simroad.envs.friction import ROAD_SURFACES, check_mu
from simroad.envs.scenarios import SCENARIO_NAMES
from simroad.errors import InvalidParameterError, SimroadError
from simroad.experiments.photos import check_road_colour
from simroad.noise import WIPER_MODES, WindscreenParams

__all__ = [
    "CAMERA_FLAGS",
    "MASK_FORMATS",
    "add_camera_options",
    "add_camera_profile",
    "add_detector_flags",
    "add_env_options",
    "add_mask_format",
    "add_sweep_camera",
    "add_worlds",
    "default_of",
    "env_options",
    "given_camera_options",
    "names",
]

#: How the photo commands read road masks (their --masks help).
MASK_FORMATS = (
    "road white on black (0/255, grey edges read above mid-grey) or 1 on 0; a label image needs --road-value, "
    "a colour mask --road-colour"
)


def default_of(owner: Callable[..., Any], name: str) -> Any:
    """The default of dataclass field or keyword parameter ``name`` of ``owner``."""
    if dataclasses.is_dataclass(owner):
        for f in dataclasses.fields(owner):
            if f.name == name:
                if f.default_factory is not dataclasses.MISSING:
                    return f.default_factory()
                return f.default
    return inspect.signature(owner).parameters[name].default


def names(values: Sequence[object]) -> str:
    """``values`` comma-joined, for help texts."""
    return ", ".join(str(v) for v in values)


def add_worlds(
    p: argparse.ArgumentParser, d: dict[str, Any], *, max_seeds: int, max_frames: int, seeds_help: str, frames_help: str
) -> None:
    """``--scenarios``, ``--seeds``, ``--seed-start`` and ``--frames``: which clear worlds a
    command renders, with the defaults ``d`` (``scenarios``, ``seeds``, ``frames``) of its
    function. ``seeds_help`` is formatted with ``n``, ``first`` and ``last`` (the default
    worlds); ``frames_help`` is the help of ``--frames`` before its default."""
    p.add_argument(
        "--scenarios",
        type=T.choice_list(SCENARIO_NAMES),
        metavar="LIST",
        default=tuple(d["scenarios"]),
        help=f"comma-separated: {names(SCENARIO_NAMES)} (default: all)",
    )
    seeds = tuple(d["seeds"])
    p.add_argument(
        "--seeds",
        type=T.int_in(1, max_seeds),
        default=len(seeds),
        help=seeds_help.format(n=len(seeds), first=seeds[0], last=seeds[-1]),
    )
    p.add_argument("--seed-start", type=T.seed(), default=seeds[0], help=f"first world seed (default: {seeds[0]})")
    p.add_argument(
        "--frames", type=T.int_in(1, max_frames), default=d["frames"], help=f"{frames_help} (default: {d['frames']})"
    )


def add_env_options(p: argparse.ArgumentParser, defaults: Callable[..., Any]) -> None:
    """Weather, scenario, camera, scenery and sensor options; the defaults of the
    first three are ``defaults``' fields, the rest :class:`RoadCamConfig`'s."""
    g = p.add_argument_group("environment")
    scenario, noise, severity = (default_of(defaults, k) for k in ("scenario", "noise", "severity"))
    g.add_argument(
        "--scenario",
        # checked by the library's config (RoadCamConfig / EpisodeSpec) before any work;
        # its message "scenario: unknown value ..." names the flag
        default=scenario,
        help=f"{names(SCENARIO_NAMES)} (default: {scenario})",
    )
    g.add_argument(
        "--noise",
        type=T.weather(),
        default=noise,
        help=f"{names(NOISE_NAMES)}, or a composition like rain+glare (default: {noise})",
    )
    g.add_argument(
        "--severity",
        type=T.float_in(0.0, 1.0),
        default=severity,
        help=f"weather severity in [0, 1] (default: {severity})",
    )
    add_camera_options(g, with_defaults=True)
    g.add_argument("--no-traffic", action="store_true", help="no other vehicles")
    _add_friction_options(g)
    _add_windscreen_options(g)
    add_camera_profile(g)


def _profile(text: str) -> CameraProfile:
    """The profile in the TOML file ``text``; a refusal keeps the library's message
    whole (it names the field or key, which argparse's flag name does not)."""
    try:
        return load_profile(text)
    except SimroadError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("camera_profile: ")) from None


#: The camera flags of :func:`add_camera_options` -> their RoadCam option.
#: The camera flags of :func:`add_camera_options`: (flag, RoadCam option, what it sets).
_CAMERA = (
    ("width", "width", "image width in pixels"),
    ("height", "height", "image height in pixels"),
    ("hfov", "hfov_deg", "horizontal field of view in degrees"),
    ("pitch", "pitch_deg", "camera pitch down in degrees"),
    ("mount-height", "mount_height_m", "camera height above the road in metres"),
    ("forward-offset", "forward_offset_m", "camera position ahead of the car's centre in metres"),
    ("scenery", "scenery", "density of the world's scenery (trees, poles, buildings, ...) in [0, 5]; 0 = bare"),
)
#: Each camera flag's argparse name -> its RoadCam option.
CAMERA_FLAGS = {flag.replace("-", "_"): option for flag, option, _ in _CAMERA}


def add_camera_options(g: argparse.ArgumentParser | argparse._ArgumentGroup, *, with_defaults: bool) -> None:
    """``--width``, ``--height``, ``--hfov``, ``--pitch``, ``--mount-height``,
    ``--forward-offset``, ``--scenery`` and ``--no-camera-effects``: the camera and the
    world's scenery. ``with_defaults`` False leaves an unset flag None (a sweep passes
    on only what was given: :func:`given_camera_options`)."""
    types = {"width": T.int_in(1, 100_000), "height": T.int_in(1, 100_000), "scenery": T.float_in(0.0, 5.0)}
    for flag, option, what in _CAMERA:  # image sizes and angles: the camera checks its own range
        default = default_of(RoadCamConfig if option == "scenery" else CameraConfig, option)
        g.add_argument(
            f"--{flag}",
            type=types.get(option, T.finite_float()),
            default=default if with_defaults else None,
            help=f"{what} (default: {default:g})",
        )
    g.add_argument(
        "--no-camera-effects",
        action="store_true",
        help="a perfect pinhole camera: no sensor (exposure, noise, response curve, vignetting, motion blur)",
    )


def add_sweep_camera(p: argparse.ArgumentParser) -> None:
    """A sweep's camera flags: ``--camera-profile`` and :func:`add_camera_options`
    without defaults (only what is given reaches the grid's ``env_options``)."""
    add_camera_profile(p)
    group = p.add_argument_group("camera of every episode (also env_options in --config)")
    add_camera_options(group, with_defaults=False)


def given_camera_options(args: argparse.Namespace) -> dict[str, Any]:
    """The RoadCam options of the camera flags that were given (:func:`add_camera_options`
    without defaults)."""
    out = {opt: getattr(args, flag) for flag, opt in CAMERA_FLAGS.items() if getattr(args, flag) is not None}
    if args.no_camera_effects:
        out["camera_effects"] = False
    return out


def add_detector_flags(p: argparse.ArgumentParser) -> None:
    """``--detector SPEC`` and ``--detector-option key=value`` (see simroad.detector.registry)."""
    p.add_argument(
        "--detector",
        type=T.detector_spec(),
        default="paper",
        metavar="SPEC",
        help="the road detector: paper (the shipped one), a registered name, package.module:attr or "
        "path/to/file.py:attr, a class or factory returning an object with predict(image) -> bool mask "
        "(default: paper)",
    )
    p.add_argument(
        "--detector-option",
        type=T.detector_option(),
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="keyword option for the detector's class or factory, the value a Python literal or a string; repeatable",
    )


def add_mask_format(p: argparse.ArgumentParser) -> None:
    """``--road-value N`` or ``--road-colour R,G,B``: how to read masks that are label or
    colour images (:func:`~simroad.experiments.photos.read_road_mask`)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--road-value",
        type=T.int_in(0, 65535),
        metavar="N",
        help="the masks are label images: the road is the value N (e.g. Cityscapes labelIds: 7)",
    )
    g.add_argument(
        "--road-colour",
        type=T.checked(check_road_colour, "colour"),
        metavar="R,G,B",
        help="the masks are colour images: the road is this colour, R,G,B or #RRGGBB (e.g. KITTI road: 255,0,255)",
    )


def add_camera_profile(g: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--camera-profile PATH``: a TOML camera profile (``simroad calibrate`` writes one),
    read and checked as it is parsed; the value is the :class:`CameraProfile`."""
    g.add_argument(
        "--camera-profile",
        type=_profile,
        default=None,
        metavar="TOML",
        help="a camera profile (exposure, white balance, tone, daylight, asphalt), e.g. from simroad calibrate "
        "(default: simroad's own)",
    )


def _mu(text: str) -> float:
    try:
        value = float(text.strip())
    except ValueError:
        raise InvalidParameterError(f"mu: expected a number in (0, 1.5], got {text!r}.") from None
    return check_mu("mu", value)


def _add_friction_options(g: argparse._ArgumentGroup) -> None:
    """``--no-friction``, ``--road-surface``, ``--mu`` (checked again by :class:`RoadCamConfig`)."""
    g.add_argument(
        "--no-friction",
        action="store_true",
        help="no tyre-road friction limit: highway-env's unlimited dynamics, drivers unaware of grip",
    )
    surface = default_of(RoadCamConfig, "road_surface")
    g.add_argument(
        "--road-surface",
        type=T.choice(ROAD_SURFACES),
        default=surface,
        help=f"{names(ROAD_SURFACES)}: friction from the weather (auto) or one surface everywhere (default: {surface})",
    )
    g.add_argument(
        "--mu",
        type=T.checked(_mu, "mu"),
        default=None,
        help="a fixed tyre-road friction coefficient in (0, 1.5] everywhere (default: from --road-surface)",
    )


def _wiper_period(text: str) -> float | str:
    """A wiper period as typed: a mode name or seconds, checked by :class:`WindscreenParams`."""
    value: float | str = text.strip().lower()
    if value not in WIPER_MODES:
        try:
            value = float(value)
        except ValueError:
            raise InvalidParameterError(
                f"wiper_period_s: expected seconds or one of {', '.join(WIPER_MODES)}, got {text!r}."
            ) from None
    WindscreenParams(wiper_period_s=value)
    return value


def _add_windscreen_options(g: argparse._ArgumentGroup) -> None:
    """``--no-windscreen`` and ``--wiper-period`` (drops on the glass with rain or snow)."""
    g.add_argument(
        "--no-windscreen",
        action="store_true",
        help="no drops on the windscreen with rain or snow (and no wiper)",
    )
    g.add_argument(
        "--wiper-period",
        type=T.checked(_wiper_period, "wiper period"),
        default=None,
        help=f"seconds between wipe cycles, or {names(tuple(WIPER_MODES))} (default: auto, a rain sensor)",
    )


def env_options(args: argparse.Namespace) -> dict[str, Any]:
    """The RoadCam keywords of the camera, scenery, sensor, friction and windscreen flags (``--width`` ...)."""
    if args.no_windscreen and args.wiper_period is not None:
        raise InvalidParameterError("--wiper-period: there is no wiper with --no-windscreen; drop one of them.")
    windscreen: bool | WindscreenParams = not args.no_windscreen
    if args.wiper_period is not None:
        windscreen = WindscreenParams(wiper_period_s=args.wiper_period)
    return {
        **{opt: getattr(args, flag) for flag, opt in CAMERA_FLAGS.items()},
        "camera_effects": not args.no_camera_effects,
        "friction": not args.no_friction,
        "road_surface": args.road_surface,
        "mu": args.mu,
        "windscreen": windscreen,
        **({"camera_profile": args.camera_profile} if args.camera_profile is not None else {}),
    }
