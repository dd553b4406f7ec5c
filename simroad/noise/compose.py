"""One way to ask for weather: a spec string, a severity, optional physical params.

``"clear"``, ``"rain"``, ``"snow"``, ``"shadow"``, ``"glare"``, ``"fog"`` and their
compositions joined by ``+`` (``"rain+glare"``, ``"snow+shadow"``). Names may come in
any order and are kept in the canonical order of :data:`NOISE_NAMES`; duplicates and
``"clear"`` inside a composition are rejected. Whatever the order of the names, the
models act in physical order, stage by stage (:data:`simroad.noise.model.STAGES`):
the surface first (wet road, settled snow, shadows, specular glare), then the
atmosphere (haze, fog), then the particles nearest the camera, then the lens (veil,
bloom) and the sensor's saturation.

Rain and snow also wet the windscreen: unless ``windscreen=False``, a weather with
rain or snow carries a :class:`~simroad.noise.windscreen.WindscreenModel` (drops on
the glass and the wiper, stage ``windscreen``, mask ``"windscreen"``) fed with the
rain's rate and the snow's flake density.

Composed models share one world: the rain's water film feeds the glare's wet lobe,
fog dims the sun for shadows and glare, shadows block the glare's specular lobe, and
``"shadow+glare"`` casts the shadows with the glare's sun.

``severity`` is keyword-only in every entry point (:func:`make_weather`,
:func:`apply_noise`, :class:`Weather`), and every ``apply`` returns a
:data:`~simroad.noise.model.NoiseResult`, ``(noisy, masks)`` with ``masks`` a dict
noise name -> bool (H, W).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from simroad.camera.geometry import PinholeCamera
from simroad.core.names import NOISE_NAMES
from simroad.core.validation import check_choice, check_in_range, normalize_rng
from simroad.errors import InvalidParameterError
from simroad.noise._windscreen_params import WindscreenParams
from simroad.noise.context import NoiseContext
from simroad.noise.fog import FogModel
from simroad.noise.glare import GlareModel
from simroad.noise.model import NoiseModel, NoiseResult, Params, run_models
from simroad.noise.rain import RainModel
from simroad.noise.shadow import ShadowModel
from simroad.noise.snow import SnowModel
from simroad.noise.windscreen import WindscreenModel

__all__ = [
    "MODELS",
    "NoiseParams",
    "Weather",
    "apply_noise",
    "check_noise_params",
    "make_weather",
    "parse_noise",
    "windscreen_model",
]

MODELS: dict[str, type[NoiseModel]] = {
    "rain": RainModel,
    "snow": SnowModel,
    "shadow": ShadowModel,
    "glare": GlareModel,
    "fog": FogModel,
}

NoiseParams = Mapping[str, Params]
"""Physical parameters per noise: noise name -> that noise's Params (e.g. ``RainParams``)."""


def parse_noise(spec: str) -> tuple[str, ...]:
    """Parse a weather spec into its model names in canonical order.

    >>> parse_noise("glare+rain")
    ('rain', 'glare')
    >>> parse_noise("clear")
    ()
    """
    if not isinstance(spec, str):
        raise InvalidParameterError(
            f"noise: expected a string such as 'rain' or 'rain+glare', got {type(spec).__name__}."
        )
    parts = [p.strip().lower() for p in spec.split("+")]
    if any(p == "" for p in parts):
        raise InvalidParameterError(f"noise: empty name in {spec!r}; join names with a single '+', e.g. 'rain+glare'.")
    for p in parts:
        check_choice("noise", p, NOISE_NAMES)
    dup = sorted({p for p in parts if parts.count(p) > 1})
    if dup:
        raise InvalidParameterError(
            f"noise: {', '.join(map(repr, dup))} given more than once in {spec!r}; name each noise once."
        )
    if "clear" in parts:
        if len(parts) > 1:
            raise InvalidParameterError(f"noise: 'clear' cannot be combined with other noises, got {spec!r}.")
        return ()
    return tuple(n for n in NOISE_NAMES if n in parts)


class Weather:
    """The weather of an episode: one model per noise, composed in physical order.

    Build with :func:`make_weather`; call :meth:`reset` at every episode start and
    :meth:`apply` once per frame, in order (rain and snow move between frames).

    Parameters
    ----------
    names : tuple of str
        Noise names in canonical order (see :func:`parse_noise`).
    severity : float
        In [0, 1], keyword-only; mapped to each model's parameters.
    params : NoiseParams, optional
        Physical parameters that replace the severity mapping for some noises.
    windscreen : bool or WindscreenParams
        Drops on the windscreen and the wiper with rain or snow (True: the default
        :class:`WindscreenParams`; False: none).

    Attributes
    ----------
    names : tuple of str
        Active noises in canonical order (empty for ``"clear"``).
    severity : float
    models : dict str -> NoiseModel
        One model per noise, plus ``"windscreen"`` (last) with rain or snow.
    """

    def __init__(
        self,
        names: tuple[str, ...],
        *,
        severity: float,
        params: NoiseParams | None = None,
        windscreen: bool | WindscreenParams = True,
    ) -> None:
        if isinstance(names, str) or not isinstance(names, (tuple, list)):
            raise InvalidParameterError(
                f"names: expected a tuple of noise names such as ('rain', 'glare') (or use make_weather('rain+glare')), "
                f"got {type(names).__name__} {names!r}."
            )
        self.names = tuple(check_choice("names", n, tuple(MODELS)) for n in names)
        dup = sorted({n for n in self.names if self.names.count(n) > 1})
        if dup:
            raise InvalidParameterError(
                f"names: {', '.join(map(repr, dup))} given more than once in {names!r}; name each noise once."
            )
        self.severity = check_in_range("severity", severity, 0.0, 1.0)
        given = check_noise_params(params, self.names)
        self.models: dict[str, NoiseModel] = {
            n: MODELS[n](given[n] if n in given else MODELS[n].params_type.from_severity(self.severity))
            for n in self.names
        }
        glass = windscreen_model(self.models, windscreen)
        if glass is not None:
            self.models["windscreen"] = glass

    @property
    def spec(self) -> str:
        """Canonical spec string, e.g. ``"rain+glare"`` or ``"clear"``."""
        return "+".join(self.names) or "clear"

    def __repr__(self) -> str:
        return f"Weather({self.spec!r}, severity={self.severity:g})"

    def reset(self, rng: np.random.Generator | int, *, world: Any = None) -> None:
        """Start an episode: every model draws its state from ``rng`` (in canonical
        order); ``world`` is the episode's WorldRaster, or ``None`` outside the env."""
        rng = normalize_rng(rng)
        for m in self.models.values():
            m.reset(rng, world=world)
        shadow, glare = self.models.get("shadow"), self.models.get("glare")
        if isinstance(shadow, ShadowModel) and isinstance(glare, GlareModel):
            shadow.set_sun(*glare.sun)

    def apply(self, image: np.ndarray, ctx: NoiseContext | None = None) -> NoiseResult:
        """Spoil one frame.

        Parameters
        ----------
        image : ndarray uint8 (H, W, 3), or float32/float64 in [0, 1]
            The clean frame (never modified).
        ctx : NoiseContext, optional
            Geometry and motion of the frame; ``None`` for a static flat-ground view.

        Returns
        -------
        noisy : ndarray, same shape and dtype as ``image``
        masks : dict str -> ndarray bool (H, W)
            Per active noise, the pixels it changed by at least
            :data:`~simroad.core.radiometry.MASK_THRESHOLD` grey levels on any channel.
        """
        return run_models(list(self.models.values()), image, ctx)


def check_noise_params(params: Any, names: tuple[str, ...] | None = None) -> dict[str, Params]:
    """Validate physical parameters per noise and return them as a dict.

    Parameters
    ----------
    params : NoiseParams or None
        A mapping noise name -> that noise's Params (``{"rain": RainParams(...)}``);
        ``None`` is no parameters.
    names : tuple of str, optional
        The weather's active noises (from :func:`parse_noise`): every key must be one
        of them. ``None``: any noise name of :data:`MODELS`.

    Returns
    -------
    dict str -> Params

    Raises
    ------
    SimroadError
        If ``params`` is not a mapping, a key is not a (active) noise name, or a value
        is not that noise's Params class.
    """
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise InvalidParameterError(f"params: expected a dict noise name -> Params, got {type(params).__name__}.")
    valid = tuple(MODELS) if names is None else names
    out = {}
    for key, value in params.items():
        check_choice("params key", key, valid or ("(none: the weather is 'clear')",))
        want = MODELS[key].params_type
        if not isinstance(value, want):
            raise InvalidParameterError(f"params[{key!r}]: expected a {want.__name__}, got {type(value).__name__}.")
        out[key] = value
    return out


def make_weather(
    spec: str,
    *,
    severity: float = 0.5,
    params: NoiseParams | None = None,
    windscreen: bool | WindscreenParams = True,
) -> Weather:
    """Build the weather for a spec string.

    Parameters
    ----------
    spec : str
        ``"clear"``, a noise name, or names joined by ``+`` (see :data:`NOISE_NAMES`).
    severity : float
        In [0, 1], keyword-only; mapped to physical parameters by each model's
        ``Params.from_severity`` (tables in the model modules and docs/weather.md).
        0 leaves frames bit-identical.
    params : NoiseParams, optional
        Physical parameters that replace the severity mapping for some noises,
        e.g. ``{"rain": RainParams(rate_mm_h=50)}`` (checked by
        :func:`check_noise_params`).
    windscreen : bool or WindscreenParams
        With rain or snow, drops on the windscreen and the wiper
        (:mod:`simroad.noise.windscreen`): True (default) with the default
        :class:`WindscreenParams`, False for none, or the parameters.

    Returns
    -------
    Weather

    Examples
    --------
    >>> weather = make_weather("rain+glare", severity=0.7)
    >>> weather.reset(np.random.default_rng(0))
    """
    return Weather(parse_noise(spec), severity=severity, params=params, windscreen=windscreen)


def apply_noise(
    image: np.ndarray,
    spec: str,
    *,
    severity: float = 0.5,
    rng: np.random.Generator | int,
    camera: PinholeCamera | None = None,
    depth: np.ndarray | None = None,
    material: np.ndarray | None = None,
    params: NoiseParams | None = None,
    windscreen: bool | WindscreenParams = True,
) -> NoiseResult:
    """Spoil a single image (a rendered frame or a photograph).

    Without ``camera`` the image is taken as seen by the default dashboard camera
    over flat ground (:func:`~simroad.noise.context.flat_ground_camera`), and without
    ``depth`` the camera's flat-ground depth is used.

    Parameters
    ----------
    image : ndarray uint8 (H, W, 3), or float32/float64 in [0, 1]
        Never modified.
    spec : str
        Weather spec (see :func:`make_weather`).
    severity : float
        In [0, 1].
    rng : numpy.random.Generator or int
        Required: the source of every random draw.
    camera : PinholeCamera, optional
        With the image's pose set.
    depth : ndarray float32 (H, W), optional
        Ground distance in m, ``inf`` for the sky.
    material : ndarray uint8 (H, W), optional
        Material codes of :mod:`simroad.camera.world`.
    params : NoiseParams, optional
        As in :func:`make_weather`.
    windscreen : bool or WindscreenParams
        As in :func:`make_weather` (the glass as the rain left it since the last wipe).

    Returns
    -------
    noisy : ndarray, same shape and dtype as ``image``
    masks : dict str -> ndarray bool (H, W)
    """
    weather = make_weather(spec, severity=severity, params=params, windscreen=windscreen)
    weather.reset(rng)
    return weather.apply(image, NoiseContext(camera=camera, depth=depth, material=material))


def windscreen_model(models: Mapping[str, NoiseModel], windscreen: Any) -> WindscreenModel | None:
    """The windscreen model for a weather's ``models``, or None.

    Parameters
    ----------
    models : dict str -> NoiseModel
        The weather's models (their rain rate and snow flake density wet the glass).
    windscreen : bool or WindscreenParams
        True: the default :class:`WindscreenParams`; False: no windscreen.

    Returns
    -------
    WindscreenModel or None
        None without rain and snow, or with ``windscreen=False``.
    """
    if not isinstance(windscreen, WindscreenParams):
        if not isinstance(windscreen, (bool, np.bool_)):
            raise InvalidParameterError(
                f"windscreen: expected True, False or a WindscreenParams, got {type(windscreen).__name__} {windscreen!r}."
            )
        if not windscreen:
            return None
        windscreen = WindscreenParams()
    rain, snow = models.get("rain"), models.get("snow")
    if rain is None and snow is None:
        return None
    return WindscreenModel(
        windscreen,
        rain_rate_mm_h=rain.params.rate_mm_h if isinstance(rain, RainModel) else 0.0,
        flake_density_m3=snow.params.flake_density_m3 if isinstance(snow, SnowModel) else 0.0,
    )
