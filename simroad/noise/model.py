"""The weather-model interface and the runner that applies models stage by stage.

A frame passes through seven stages in physical order, and every model acts in the
stages it belongs to (see :data:`STAGES`): what the surface is made of (wet road,
settled snow), how it is lit (cast shadows), what it reflects (wet-road sky mirror,
the sun's specular lobe), the atmosphere between surface and camera (haze, fog), the
particles nearest the camera (drops, flakes), the windscreen (drops on the glass, the
wiper), and the optics (veiling glare, bloom).

Every public way to apply weather returns a :data:`NoiseResult`, ``(noisy, masks)``:
the spoiled frame (same shape and dtype as the input) and a dict noise name -> bool
(H, W) mask of the pixels that noise changed by at least
:data:`~simroad.core.radiometry.MASK_THRESHOLD` grey levels (the sky turning clear
when a model brings out the sun is a change of weather, not noise: it stays out of
the masks).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np

from simroad.core.radiometry import MASK_THRESHOLD, as_uint8, change_mask, linear_to_srgb, srgb_to_linear
from simroad.core.validation import (
    check_bool,
    check_finite_number,
    check_image,
    check_in_range,
    check_int_in_range,
    normalize_rng,
)
from simroad.errors import InvalidParameterError, ResetNeededError
from simroad.noise._encode_kernel import encode_touched
from simroad.noise.context import FrameState, NoiseContext, resolve_frame

__all__ = ["STAGES", "Limit", "NoiseModel", "NoiseResult", "Params", "run_models"]

STAGES = ("material", "illumination", "reflection", "atmosphere", "particles", "windscreen", "optics")
#: The stages that act on the ground's surface only.
_SURFACE_STAGES = ("material", "reflection")

NoiseResult = tuple[np.ndarray, dict[str, np.ndarray]]
"""``(noisy, masks)``: the frame (input's shape and dtype) and noise name -> bool (H, W)."""


@dataclass(frozen=True)
class Limit:
    """The valid range of one numeric field of a :class:`Params` class.

    Parameters
    ----------
    low, high : float
        Bounds of the range (``high`` always included).
    unit : str
        Unit of the field, shown in errors and documentation.
    low_inclusive : bool
        Whether ``low`` itself is valid.
    integer : bool
        The field is an integer count.
    optional : bool
        ``None`` is valid too (e.g. a sun azimuth drawn per episode).
    length : int, optional
        The field is a tuple of this many values, each in the range.
    """

    low: float
    high: float
    unit: str = ""
    low_inclusive: bool = True
    integer: bool = False
    optional: bool = False
    length: int | None = None

    def __post_init__(self) -> None:
        low = check_finite_number("low", self.low)
        high = check_finite_number("high", self.high)
        if low > high:
            raise InvalidParameterError(f"low: expected at most high={high:g}, got {low:g}.")
        if self.length is not None:
            check_int_in_range("length", self.length, 1, 1000)

    def check(self, name: str, value: Any) -> Any:
        """Return ``value`` validated (as float, int or tuple of float), else raise naming ``name``."""
        if value is None and self.optional:
            return None
        if self.length is None:
            return self._check_one(name, value)
        if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
            raise InvalidParameterError(
                f"{name}: expected {self.length} values (a tuple such as {(1.0,) * self.length}), "
                f"got {type(value).__name__} {value!r}."
            )
        values = tuple(value)
        if len(values) != self.length:
            raise InvalidParameterError(f"{name}: expected {self.length} values, got {len(values)}.")
        return tuple(self._check_one(f"{name}[{k}]", v) for k, v in enumerate(values))

    def _check_one(self, name: str, value: Any) -> float | int:
        if self.integer:
            return check_int_in_range(name, value, int(self.low), int(self.high))
        return check_in_range(name, value, self.low, self.high, unit=self.unit, low_inclusive=self.low_inclusive)

    def describe(self) -> str:
        """The range as text, e.g. ``"[0, 300] mm/h"`` or ``"integer in [0, 200000]"``."""
        lb = "[" if self.low_inclusive else "("
        text = f"{lb}{self.low:g}, {self.high:g}]" + (f" {self.unit}" if self.unit else "")
        if self.integer:
            text = "integer in " + text
        if self.length is not None:
            text = f"{self.length} values, each in {text}"
        if self.optional:
            text += ", or None"
        return text


@dataclass(frozen=True)
class Params:
    """Base of the per-model parameter dataclasses.

    Subclasses declare the valid range of every numeric field once, in the class
    table ``LIMITS`` (field name -> :class:`Limit`): construction validates against it
    and the Notes section of the class docstring is generated from it.
    ``bool`` fields take True/False (numpy bools and the integers 0 and 1 too);
    anything else, such as the string ``"no"``, is refused.
    """

    LIMITS: ClassVar[Mapping[str, Limit]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__doc__ and cls.LIMITS:
            cls.__doc__ = cls.__doc__.rstrip() + "\n\n" + cls.limits_doc() + "\n"

    @classmethod
    def limits_doc(cls) -> str:
        """The numpydoc Notes section listing ``LIMITS``, indented for a class docstring."""
        width = max(len(n) for n in cls.LIMITS)
        lines = ["    Notes", "    -----", "    Valid ranges, checked on construction (from ``LIMITS``)::", ""]
        lines += [f"        {n:<{width}}  {lim.describe()}" for n, lim in cls.LIMITS.items()]
        return "\n".join(lines)

    def __post_init__(self) -> None:
        for name, limit in self.LIMITS.items():
            object.__setattr__(self, name, limit.check(name, getattr(self, name)))
        for f in fields(self):
            if f.type in ("bool", bool):
                object.__setattr__(self, f.name, _check_flag(f.name, getattr(self, f.name)))

    @classmethod
    def from_severity(cls, severity: float) -> Params:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def is_identity(self) -> bool:
        """True when these parameters leave every frame unchanged."""
        raise NotImplementedError  # pragma: no cover - abstract


def _check_flag(name: str, value: Any) -> bool:
    """A bool field: True/False, numpy bools, or the integers 0 and 1."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value in (0, 1):
        return bool(value)
    return check_bool(name, value)


class NoiseModel:
    """One weather model: parameters, per-episode state, and the stages it acts in.

    Subclasses set ``name``, ``params_type`` and ``stages`` and implement a method per
    stage, ``method(state: FrameState) -> None``, that changes ``state.lin`` in place;
    ``prepare(state)`` runs for every model before the first stage.
    """

    name: ClassVar[str] = ""
    params_type: ClassVar[type[Params]] = Params
    stages: ClassVar[tuple[str, ...]] = ()

    def __init__(self, params: Params) -> None:
        if not isinstance(params, self.params_type):
            raise InvalidParameterError(
                f"params: the {self.name!r} model takes {self.params_type.__name__}, got {type(params).__name__}."
            )
        self.params: Any = params
        self._rng: np.random.Generator | None = None
        self._world: Any = None
        self._seed = 0

    @classmethod
    def from_severity(cls, severity: float) -> NoiseModel:
        """The model with the documented parameters for ``severity`` in [0, 1]."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(cls.params_type.from_severity(s))

    def reset(self, rng: np.random.Generator | int, *, world: Any = None) -> None:
        """Start an episode: draw this model's random state from ``rng``.

        Parameters
        ----------
        rng : numpy.random.Generator or int
            The episode's generator (one integer seed is drawn from it).
        world : WorldRaster, optional
            The episode's world (used by models that place things in it).
        """
        rng = normalize_rng(rng)
        seed = int(rng.integers(0, 2**63 - 1))
        self._seed = seed
        self._rng = np.random.default_rng(seed)
        self._world = world
        self._on_reset()

    def _on_reset(self) -> None:
        """Hook for subclasses: clear per-episode state."""

    def _require_reset(self) -> np.random.Generator:
        if self._rng is None:
            raise ResetNeededError(f"{self.name}: call reset(rng) before apply(...).")
        return self._rng

    @property
    def is_identity(self) -> bool:
        """True when this model leaves every frame unchanged (its params say so)."""
        return bool(self.params.is_identity)

    def prepare(self, state: FrameState) -> None:
        """Hook run before the first stage of every frame."""

    def apply(self, image: np.ndarray, ctx: NoiseContext | None = None) -> NoiseResult:
        """Apply this model alone to one frame (the input is never modified).

        Returns
        -------
        noisy : ndarray, same shape and dtype as ``image``
        masks : dict str -> ndarray bool (H, W)
            ``{self.name: mask}``, the pixels changed by at least
            :data:`~simroad.core.radiometry.MASK_THRESHOLD` grey levels, as
            :meth:`simroad.noise.Weather.apply` returns them.
        """
        return run_models([self], image, ctx)


def run_models(models: Sequence[NoiseModel], image: np.ndarray, ctx: NoiseContext | None = None) -> NoiseResult:
    """Run models stage by stage on one frame; the input is never modified.

    Returns
    -------
    noisy : ndarray, same shape and dtype as ``image``
    masks : dict str -> ndarray bool (H, W)
        One mask per model, keyed by model name.
    """
    image = check_image("image", image, dtype=("uint8", "float32", "float64"), channels=3, min_size=16)
    if ctx is None:
        ctx = NoiseContext()
    elif not isinstance(ctx, NoiseContext):
        raise InvalidParameterError(f"ctx: expected a NoiseContext, got {type(ctx).__name__}.")
    h, w = image.shape[:2]
    masks = {m.name: np.zeros((h, w), dtype=bool) for m in models}
    active = [m for m in models if not m.is_identity]
    for m in active:
        m._require_reset()
    cam, depth, material, ground = resolve_frame(image, ctx)
    if not active:
        return image.copy(), masks
    state = FrameState(srgb_to_linear(image), cam, depth, material, ground, ctx)
    for m in active:
        m.prepare(state)
    plan = [(stage, m) for stage in STAGES for m in active if stage in m.stages]
    if state.ground_rows.stop <= state.ground_rows.start:
        # No ground in view (a wall or a truck fills the frame): the stages that act
        # on the road surface have nothing to act on.
        plan = [(stage, m) for stage, m in plan if stage not in _SURFACE_STAGES]
    enc_prev = as_uint8(image)
    encoded = False  # whether enc_prev is linear_to_srgb(state.lin) (not the input)
    several = False  # whether the pending update covers more than one stage
    for k, (stage, m) in enumerate(plan):
        getattr(m, stage)(state)
        if k + 1 < len(plan) and plan[k + 1][1] is m:
            state.touched, several = None, True
            continue  # same model again: one mask update covers both stages
        if state.touched is not None and encoded and not several:  # a few pixels changed: encode those
            enc, changed = encode_touched(state.lin, state.touched, enc_prev, MASK_THRESHOLD)
        else:
            enc = linear_to_srgb(state.lin)
            changed = change_mask(enc_prev, enc)
        state.touched, encoded, several = None, True, False
        if state.unmasked is not None:  # the sky clearing for the sun is not noise
            changed &= ~state.unmasked
            state.unmasked = None
        if state.covered is not None:  # what covers the lens is noise even where it matches the scene
            changed |= state.covered
            state.covered = None
        masks[m.name] |= changed
        enc_prev = enc
    if image.dtype == np.uint8:
        return enc_prev, masks
    return linear_to_srgb(state.lin, image.dtype), masks
