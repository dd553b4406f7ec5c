"""Typed configuration of :class:`simroad.envs.RoadCamEnv`."""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from simroad.camera.geometry import CameraConfig
from simroad.camera.palette import ROADSIDE_KINDS
from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.camera.sensor_params import SensorParams
from simroad.core.validation import check_bool, check_choice, check_in_range
from simroad.envs.friction import ROAD_SURFACES, check_mu
from simroad.envs.scenarios import SCENARIO_NAMES, SCENARIOS
from simroad.errors import InvalidParameterError, SimroadError
from simroad.noise import MODELS, WindscreenParams, parse_noise

__all__ = ["ENV_OPTION_KEYS", "RoadCamConfig"]

_CAMERA_KEYS = tuple(f.name for f in dataclasses.fields(CameraConfig))


@dataclass(frozen=True)
class RoadCamConfig:
    """Everything that defines a ``simroad/RoadCam-v0`` environment.

    Parameters
    ----------
    scenario : str
        A key of :data:`simroad.envs.scenarios.SCENARIOS` (``racetrack``, ``highway``,
        ``winding``, ``town``).
    camera : CameraConfig
        Image size, field of view, mounting (see :class:`CameraConfig`).
    noise : str
        Weather spec: ``"clear"``, ``"rain"``, ``"snow"``, ``"shadow"``, ``"glare"``,
        ``"fog"`` or a composition such as ``"rain+glare"``.
    severity : float
        Weather severity in [0, 1], mapped to physical parameters (docs/weather.md).
    noise_params : dict, optional
        Physical parameters per noise, overriding the severity mapping, e.g.
        ``{"rain": RainParams(rate_mm_h=50)}``; every key must be one of the active
        noises of ``noise`` (parameters for a noise that is not active are refused).
    longitudinal : bool
        If True the action is ``[steering, acceleration]``, else ``[steering]`` at
        constant speed.
    traffic : bool
        Other vehicles on the road.
    duration_s : float
        Episode time limit in simulated seconds (truncation), from one policy period
        of the scenario (0.2 s) to 3600 s.
    roadside : str, optional
        Force the roadside material (grass, dirt, gravel, pavement); drawn per seed
        when None.
    max_offroad_m : float
        The episode terminates when the ego's centre is farther than this from the
        road surface, in metres.
    camera_effects : bool or SensorParams
        The camera sensor after the weather (auto-exposure, response curve, shot and
        read noise, ADC, vignetting, motion blur, optional JPEG; docs/camera.md).
        True (default) uses the default :class:`SensorParams`; False is the perfect
        pinhole (frames bit-identical to the renderer and weather output).
    scenery : float
        Density scale of the world's scenery (trees, poles, signs, buildings, walls,
        guard rails, overpasses; :mod:`simroad.camera.scenery`) in [0, 5]: 0 is a
        bare world, 1 the scenario's profile, higher values denser.
    friction : bool
        Tyre–road friction limits the ego's and the traffic's dynamics (the friction
        circle, :mod:`simroad.envs.friction`); False is highway-env's unlimited
        kinematics (and ``info["mu"]`` is None), to separate what the weather costs
        the dynamics from what it costs perception.
    road_surface : str
        ``"auto"``: μ from the weather (dry, wet by water film, slush, settled snow);
        or one surface everywhere: ``dry``, ``wet``, ``slush``, ``snow``, ``ice``
        (:data:`simroad.envs.friction.SURFACES`).
    mu : float, optional
        A fixed friction coefficient in (0, 1.5] everywhere (with
        ``road_surface="auto"`` only). Both are refused with ``friction=False``.
    windscreen : bool or WindscreenParams
        With rain or snow, drops on the windscreen and the wiper
        (:mod:`simroad.noise.windscreen`, noise mask ``"windscreen"``): True (default)
        with the default :class:`WindscreenParams` (a rain-sensing wiper), False for a
        dry glass, or the parameters, e.g. ``WindscreenParams(wiper_period_s=1.5)``.
    camera_profile : CameraProfile or str, optional
        How a clear day looks (:mod:`simroad.camera.profile`): the daylight and
        asphalt worlds are drawn from, and the camera's exposure bias, white balance,
        response curve and full well (these replace the sensor's). A
        :class:`CameraProfile`, a dict of its fields, or the path of a TOML profile
        (``simroad calibrate`` writes one); None is simroad's default profile.
    """

    scenario: str = "racetrack"
    camera: CameraConfig = field(default_factory=CameraConfig)
    noise: str = "clear"
    severity: float = 0.5
    noise_params: dict | None = None
    longitudinal: bool = False
    traffic: bool = True
    duration_s: float = 60.0
    roadside: str | None = None
    max_offroad_m: float = 3.0
    camera_effects: bool | SensorParams = True
    scenery: float = 1.0
    friction: bool = True
    road_surface: str = "auto"
    mu: float | None = None
    windscreen: bool | WindscreenParams = True
    camera_profile: CameraProfile | None = None

    def __post_init__(self) -> None:
        check_choice("scenario", self.scenario, SCENARIO_NAMES)
        if not isinstance(self.camera, CameraConfig):
            raise InvalidParameterError(f"camera: expected a CameraConfig, got {type(self.camera).__name__}.")
        object.__setattr__(self, "severity", check_in_range("severity", self.severity, 0.0, 1.0))
        period = SCENARIOS[self.scenario].policy_period_s  # at least one policy step
        object.__setattr__(self, "duration_s", check_in_range("duration_s", self.duration_s, period, 3600.0, unit="s"))
        object.__setattr__(
            self, "max_offroad_m", check_in_range("max_offroad_m", self.max_offroad_m, 0.0, 50.0, unit="m")
        )
        if self.roadside is not None:
            check_choice("roadside", self.roadside, ROADSIDE_KINDS)
        if not isinstance(self.noise, str):
            raise InvalidParameterError(f"noise: expected a string such as 'rain' or 'rain+glare', got {self.noise!r}.")
        object.__setattr__(self, "noise", "+".join(parse_noise(self.noise)) or "clear")
        object.__setattr__(self, "scenery", check_in_range("scenery", self.scenery, 0.0, 5.0))
        check_bool("longitudinal", self.longitudinal)
        check_bool("traffic", self.traffic)
        _check_noise_params(self.noise_params, self.noise)
        _check_friction(self.friction, self.road_surface, self.mu)
        if not isinstance(self.camera_effects, SensorParams):
            check_bool("camera_effects", self.camera_effects)
            object.__setattr__(self, "camera_effects", bool(self.camera_effects))
        if self.camera_profile is not None:
            object.__setattr__(self, "camera_profile", _profile(self.camera_profile))
        if not isinstance(self.windscreen, WindscreenParams):
            check_bool("windscreen", self.windscreen)
            object.__setattr__(self, "windscreen", bool(self.windscreen))

    @property
    def sensor_params(self) -> SensorParams | None:
        """The camera sensor's parameters, or None when ``camera_effects`` is off."""
        if self.camera_effects is False:
            return None
        params = self.camera_effects if isinstance(self.camera_effects, SensorParams) else SensorParams()
        cp = self.camera_profile
        if cp is None:
            return params
        return params.with_profile(cp)

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> RoadCamConfig:
        """Build from flat keyword arguments; camera keys (``width``, ``pitch_deg``, ...)
        may be given directly. Unknown keys are refused with a suggestion."""
        own = {f.name for f in dataclasses.fields(cls)}
        valid = sorted(own | set(_CAMERA_KEYS))
        cam_kw, own_kw = {}, {}
        for key, value in kwargs.items():
            if key in _CAMERA_KEYS:
                cam_kw[key] = value
            elif key in own:
                own_kw[key] = value
            else:
                close = difflib.get_close_matches(key, valid, n=1)
                hint = f" Did you mean {close[0]!r}?" if close else ""
                raise InvalidParameterError(
                    f"unknown RoadCam option {key!r}; valid options are {', '.join(valid)}.{hint}"
                )
        if cam_kw:
            if "camera" in own_kw:
                raise InvalidParameterError(
                    "camera: pass either camera=CameraConfig(...) or camera keywords, not both."
                )
            own_kw["camera"] = CameraConfig(**cam_kw)
        return cls(**own_kw)


#: Every keyword RoadCam takes (its config's fields and the camera's, given flat).
ENV_OPTION_KEYS: tuple[str, ...] = tuple(
    sorted({f.name for f in dataclasses.fields(RoadCamConfig)} | set(_CAMERA_KEYS))
)


def _profile(value: Any) -> CameraProfile:
    """``value`` resolved to a profile; a refusal names ``camera_profile`` whatever field
    of the profile it is about."""
    try:
        return resolve_profile(value)
    except SimroadError as exc:
        text = str(exc)
        raise InvalidParameterError(text if text.startswith("camera_profile") else f"camera_profile: {text}") from None


def _check_friction(friction: Any, road_surface: Any, mu: Any) -> None:
    """Refuse a non-bool ``friction``, an unknown ``road_surface`` and an invalid or
    conflicting ``mu``, each by name."""
    check_bool("friction", friction)
    check_choice("road_surface", road_surface, ROAD_SURFACES)
    if not friction and (road_surface != "auto" or mu is not None):
        name = "mu" if mu is not None else "road_surface"
        raise InvalidParameterError(
            f"{name}: set to {mu if mu is not None else road_surface!r} with friction=False, where it has no effect; "
            "drop it or turn friction on."
        )
    if mu is not None:
        check_mu("mu", mu)
        if road_surface != "auto":
            raise InvalidParameterError(
                f"mu: a fixed mu={mu!r} and road_surface={road_surface!r} both set the friction; give one of them."
            )


def _check_noise_params(params: Any, noise: str) -> None:
    """Refuse ``noise_params`` that are not a dict of the active noises' Params."""
    if params is None:
        return
    if not isinstance(params, Mapping):
        raise InvalidParameterError(
            f"noise_params: expected a dict noise name -> Params such as {{'rain': RainParams(...)}}, "
            f"got {type(params).__name__}."
        )
    active = parse_noise(noise)
    for key, value in params.items():
        if key not in active:
            where = f"the active noises are {', '.join(map(repr, active))}" if active else "the weather is 'clear'"
            raise InvalidParameterError(
                f"noise_params: parameters for {key!r}, which is not active (noise={noise!r}; {where}). "
                f"Add {key!r} to noise (e.g. noise='{noise}+{key}') or drop its parameters."
                if active
                else f"noise_params: parameters for {key!r}, but {where}. Set noise={key!r} or drop noise_params."
            )
        want = MODELS[key].params_type
        if not isinstance(value, want):
            raise InvalidParameterError(
                f"noise_params[{key!r}]: expected a {want.__name__}, got {type(value).__name__}."
            )
