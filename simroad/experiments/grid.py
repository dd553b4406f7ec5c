"""The ablation grid: which episodes a sweep runs, from flags or a TOML file."""

from __future__ import annotations

import difflib
import hashlib
import json
import os
import tomllib
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from functools import partial
from pathlib import Path
from typing import Any

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.validation import (
    check_bool,
    check_choice,
    check_finite_number,
    check_in_range,
    check_int_in_range,
)
from simroad.detector.registry import check_detector, resolve_factory
from simroad.envs.config import ENV_OPTION_KEYS, RoadCamConfig
from simroad.envs.scenarios import SCENARIO_NAMES
from simroad.errors import InvalidParameterError, SimroadError
from simroad.experiments.episode import EpisodeSpec, options_record
from simroad.filters.pipeline import format_filters, parse_filters
from simroad.noise import parse_noise

__all__ = ["AblationGrid", "cell_key", "load_grid_file"]


def _split(name: str, value: Any) -> list[str]:
    if isinstance(value, str):
        items = [v.strip() for v in value.split(",")]
    elif isinstance(value, (list, tuple)):
        items = [str(v).strip() for v in value]
    else:
        raise InvalidParameterError(f"{name}: expected a comma-separated string or a list, got {value!r}.")
    items = [v for v in items if v]
    if not items:
        raise InvalidParameterError(f"{name}: the list is empty; give at least one value.")
    return items


def _canonical_noise(spec: str) -> str:

    try:
        return "+".join(parse_noise(spec)) or "clear"
    except SimroadError as exc:
        raise InvalidParameterError(f"noises: {exc}") from None


def _numbers(name: str, value: Any) -> list[float]:
    """A comma-separated string or a list of numbers as floats, naming the bad item."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value]
    items = value if isinstance(value, (list, tuple)) else _split(name, value)
    if not items:
        raise InvalidParameterError(f"{name}: the list is empty; give at least one value.")
    out = []
    for item in items:
        if isinstance(item, str):
            try:
                item = float(item.strip())
            except ValueError:
                raise InvalidParameterError(
                    f"{name}: {item!r} is not a number; expected numbers such as 0.3,0.7 (in {value!r})."
                ) from None
        out.append(check_finite_number(name, item))
    return out


@dataclass(frozen=True)
class AblationGrid:
    """detectors x filter sets x scenarios x noises x severities x seeds, plus one
    oracle row per scenario x noise x severity x seed.

    ``clear`` weather has no severity: it runs once, recorded with severity 0.
    ``detectors`` are detector specs (``paper``, a registered name, ``module:attr``,
    ``path/to/file.py:attr``; :mod:`simroad.detector.registry`), each built with its
    ``detector_options[spec]`` (keyword options) and the filter set in front.
    ``friction=False`` runs every episode without tyre–road friction (RoadCam's
    ``friction`` option), to separate perception losses from dynamics losses.
    ``camera_profile`` (a :class:`~simroad.camera.profile.CameraProfile`, a dict of
    its fields or the path of a TOML profile, e.g. from ``simroad calibrate``) is
    every episode's camera (RoadCam's ``camera_profile``); None is simroad's default.
    ``env_options`` are further RoadCam options for every episode -- the camera
    (``width``, ``height``, ``hfov_deg``, ``pitch_deg``, ``mount_height_m``,
    ``forward_offset_m``, ...), ``scenery``, ``camera_effects``, ``windscreen``,
    ``road_surface``, ``mu``, ``max_offroad_m`` -- checked as RoadCam checks them; the
    options the grid sets itself (scenario, weather, traffic, friction, camera profile,
    duration) are refused there with the field to use instead.
    """

    scenarios: tuple[str, ...] = ("racetrack", "winding")
    noises: tuple[str, ...] = ("clear", "rain", "snow", "shadow", "glare")
    severities: tuple[float, ...] = (0.7,)
    filters: tuple[str, ...] = ("none", "all")
    seeds: int = 3
    seed_start: int = 0
    steps: int = 150
    traffic: bool = True
    oracle: bool = True
    detectors: tuple[str, ...] = ("paper",)
    detector_options: dict = field(default_factory=dict)
    friction: bool = True
    camera_profile: CameraProfile | None = None
    env_options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        scen = tuple(check_choice("scenarios", s, SCENARIO_NAMES) for s in _split("scenarios", self.scenarios))
        noises = tuple(_canonical_noise(n) for n in _split("noises", self.noises))
        sev = tuple(check_in_range("severities", v, 0.0, 1.0) for v in _numbers("severities", self.severities))
        filt = tuple(format_filters(parse_filters(f)) for f in _split("filters", self.filters))
        dets = tuple(str(d).strip() for d in _split("detectors", self.detectors))
        for d in dets:
            try:
                resolve_factory(d)
            except SimroadError as exc:
                raise InvalidParameterError(f"detectors: {exc}") from None
        for name, vals in (
            ("scenarios", scen), ("noises", noises), ("severities", sev), ("filters", filt), ("detectors", dets)
        ):  # fmt: skip
            if len(set(vals)) != len(vals):
                raise InvalidParameterError(f"{name}: duplicate values in {list(vals)}.")
        object.__setattr__(self, "scenarios", scen)
        object.__setattr__(self, "noises", noises)
        object.__setattr__(self, "severities", sev)
        object.__setattr__(self, "filters", filt)
        object.__setattr__(self, "detectors", dets)
        object.__setattr__(self, "detector_options", _detector_options(self.detector_options, dets))
        # stored as plain ints: 2.0 or numpy integers would reach range() and grid.json
        object.__setattr__(self, "seeds", check_int_in_range("seeds", self.seeds, 1, 100_000))
        object.__setattr__(
            self, "seed_start", check_int_in_range("seed_start", self.seed_start, 0, 2**31 - 1 - self.seeds)
        )
        object.__setattr__(self, "steps", check_int_in_range("steps", self.steps, 1, 1_000_000))
        check_bool("traffic", self.traffic)
        check_bool("oracle", self.oracle)
        check_bool("friction", self.friction)
        object.__setattr__(self, "env_options", _grid_env_options(self.env_options))
        if self.camera_profile is not None:
            try:
                profile = resolve_profile(self.camera_profile)
            except SimroadError as exc:  # name the grid's key, whatever field the profile refused
                text = str(exc)
                raise InvalidParameterError(
                    text if text.startswith("camera_profile") else f"camera_profile: {text}"
                ) from None
            object.__setattr__(self, "camera_profile", profile)

    def specs(self) -> list[EpisodeSpec]:
        """Every episode of the grid, in a fixed order."""
        out = []
        for scenario in self.scenarios:
            for noise in self.noises:
                for severity in (0.0,) if noise == "clear" else self.severities:
                    for seed in range(self.seed_start, self.seed_start + self.seeds):
                        base = partial(
                            EpisodeSpec,
                            scenario=scenario,
                            noise=noise,
                            severity=severity,
                            seed=seed,
                            steps=self.steps,
                            traffic=self.traffic,
                            env_options=self._env_options(),
                        )
                        if self.oracle:
                            out.append(base(driver="oracle"))
                        for d in self.detectors:
                            opts = self.detector_options.get(d, {})
                            for f in self.filters:
                                out.append(
                                    base(driver="detector", filters=parse_filters(f), detector=d, detector_options=opts)
                                )
        return out

    def _env_options(self) -> dict[str, Any]:
        """The RoadCam options every episode of the grid shares."""
        options: dict[str, Any] = dict(self.env_options)
        if not self.friction:
            options["friction"] = False
        if self.camera_profile is not None:
            options["camera_profile"] = self.camera_profile
        return options

    def grows(self, old: Mapping[str, Any]) -> bool:
        """Whether this grid holds every cell of the grid whose fields are ``old`` (as
        ``grid.json`` records them), each run the same way: the same steps, traffic,
        friction, camera profile and env options, and the same options for each of the
        old detectors. Such a grid may take over the old one's results and run only its
        new cells (more detectors, filter sets, weathers, seeds...)."""
        try:
            prev = AblationGrid(**old)
        except (TypeError, SimroadError):
            return False  # another version's grid.json, or options this one cannot rebuild
        mine, theirs = asdict(self), asdict(prev)
        if any(mine[k] != theirs[k] for k in ("steps", "traffic", "friction", "camera_profile", "env_options")):
            return False
        if any(self.detector_options.get(d, {}) != prev.detector_options.get(d, {}) for d in prev.detectors):
            return False
        cells = {cell_key(s) for s in self.specs()}
        return all(cell_key(s) in cells for s in prev.specs())

    def fingerprint(self) -> str:
        """A digest of everything that defines the grid's results (a grid without a
        camera profile or env options digests as before those fields existed, so its
        sweeps resume)."""
        fields_ = asdict(self)
        for key in ("camera_profile", "env_options"):  # absent before these fields existed
            if not fields_[key]:
                del fields_[key]
        if self.env_options:
            fields_["env_options"] = options_record(self.env_options)
        text = json.dumps(fields_, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def cell_key(spec_or_record: EpisodeSpec | Mapping[str, Any], *, default_budget: int | None = None) -> str:
    """The identity of one grid cell (one episode), from its spec or its record: the
    world, weather, filters, driver, detector, seed and step budget.

    A record written before records held ``step_budget`` takes ``default_budget`` (the
    ``steps`` of the sweep's ``grid.json``) or, without one, the steps it drove."""

    def get(key: str) -> Any:
        if isinstance(spec_or_record, Mapping):
            return spec_or_record[key]
        return getattr(spec_or_record, key)

    filters = get("filters")
    filters = filters if isinstance(filters, str) else format_filters(filters)
    if isinstance(spec_or_record, Mapping):
        detector = spec_or_record.get("detector_spec", "")
        budget = spec_or_record.get("step_budget", default_budget if default_budget is not None else get("steps"))
    else:
        detector = spec_or_record.detector if spec_or_record.driver == "detector" else ""
        budget = spec_or_record.steps
    return (
        f"{get('scenario')}|{get('noise')}|{float(get('severity')):g}|{filters}|{get('driver')}|{detector}"
        f"|{int(get('seed'))}|{int(budget)} steps"
    )


#: RoadCam options the grid sets itself, with the field that sets each.
_GRID_OWNS = {
    "scenario": "scenarios", "noise": "noises", "severity": "severities", "traffic": "traffic",
    "friction": "friction", "camera_profile": "camera_profile", "duration_s": "steps", "longitudinal": None,
}  # fmt: skip


def _grid_env_options(options: Any) -> dict[str, Any]:
    """``options`` as a dict of RoadCam options every episode shares, checked by RoadCam."""
    if not isinstance(options, Mapping):
        raise InvalidParameterError(
            f"env_options: expected a table of RoadCam options such as {{'width': 640, 'height': 360}}, "
            f"got {type(options).__name__}."
        )
    for key in options:
        if key in _GRID_OWNS:
            field_ = _GRID_OWNS[key]
            how = f"use its field {field_!r} instead" if field_ else "a sweep's drivers always control the speed"
            raise InvalidParameterError(f"env_options: {key!r} is set by the grid itself; {how}.")
    try:
        RoadCamConfig.from_kwargs(**options)
    except SimroadError as exc:
        raise InvalidParameterError(f"env_options: {exc}") from None
    return dict(options)


def _detector_options(options: Any, detectors: tuple[str, ...]) -> dict[str, dict]:
    """``{spec: {key: value}}`` for specs of ``detectors`` only."""
    if not isinstance(options, Mapping):
        raise InvalidParameterError(
            f"detector_options: expected a table of detector spec -> options, e.g. "
            f"{{'mine.py:Detector': {{'threshold': 0.5}}}}, got {type(options).__name__}."
        )
    out = {}
    for spec, opts in options.items():
        if spec not in detectors:
            raise InvalidParameterError(
                f"detector_options: {spec!r} is not one of the grid's detectors {list(detectors)}; "
                "give options only for a detector the grid runs."
            )
        out[spec] = check_detector(spec, opts)[1]
    return out


def load_grid_file(path: str | os.PathLike) -> dict[str, Any]:
    """Read a TOML grid file; keys are AblationGrid's fields (``seed-start`` or
    ``seed_start``) plus ``workers``, ``backend``, ``ray_address``, ``out``; RoadCam
    options (``width = 640``, ``hfov_deg = 90``, or an ``[env_options]`` table) go to
    ``env_options``. A
    ``camera_profile`` path is taken relative to the grid file's folder; it may also
    be a ``[camera_profile]`` table of the profile's fields."""
    p = Path(path)
    if p.is_dir():
        raise InvalidParameterError(
            f"config: {str(p)!r} is a directory; give a TOML file such as {str(p / 'grid.toml')!r}."
        )
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8-sig"))  # UTF-8, with or without a BOM (Windows editors)
    except FileNotFoundError:
        raise InvalidParameterError(f"config: file {str(p)!r} not found.") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InvalidParameterError(f"config: {str(p)!r} is not valid TOML ({exc}).") from None
    except OSError as exc:
        raise InvalidParameterError(f"config: cannot read {str(p)!r} ({exc.strerror}).") from None
    valid = [f.name for f in fields(AblationGrid)] + ["workers", "backend", "ray_address", "out"]
    env_keys = [k for k in ENV_OPTION_KEYS if k not in _GRID_OWNS]
    out: dict[str, Any] = {}
    for key, value in data.items():
        k = key.replace("-", "_")
        if k in env_keys:  # a RoadCam option at the top level, e.g. width = 640
            out.setdefault("env_options", {})[k] = value
            continue
        if k == "env_options" and isinstance(value, Mapping):
            out.setdefault("env_options", {}).update(value)
            continue
        if k not in valid:
            close = difflib.get_close_matches(k, valid + env_keys, n=1)
            hint = f" Did you mean {close[0]!r}?" if close else ""
            raise InvalidParameterError(
                f"config: unknown key {key!r} in {str(p)!r}; valid keys are {', '.join(valid)}.{hint}"
            )
        out[k] = _check_run_key(k, value, p) if k in RUN_KEY_TYPES else value
    if isinstance(out.get("camera_profile"), str):  # a profile file next to the grid file
        out["camera_profile"] = str(p.parent / Path(out["camera_profile"]).expanduser())
    return out


#: Keys of a grid file (and ``simroad ablate`` flags) that configure the run, not the
#: grid, with what each must be.
RUN_KEY_TYPES: dict[str, str] = {
    "workers": "an integer >= 1",
    "backend": "a string ('local' or 'ray')",
    "ray_address": "a string such as 'auto' or '10.0.0.1:6379'",
    "out": "a directory path string",
}


def _check_run_key(key: str, value: Any, path: Path) -> Any:
    """A run key's value of the right type, else an error naming the key and the file."""
    if key == "workers":
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= 1
    else:
        ok = isinstance(value, str) and value.strip() != ""
    if not ok:
        raise InvalidParameterError(
            f"config: {key} in {str(path)!r}: expected {RUN_KEY_TYPES[key]}, got {type(value).__name__} {value!r}."
        )
    return value
