"""Shared machinery of the weather models: radiometry, the per-frame context, the
model interface and the runner that composes models in physical order.

Radiometry
----------
Frames are treated as sRGB-encoded with a display gamma of 2.2. Every model works on
*linear* relative radiance (float32, 1.0 = a white Lambertian surface under the
scene's illumination, which is the camera's exposure reference), because light adds
and attenuates linearly there: the paper's eq. 19 blend, Koschmieder's law and the
dichromatic model's sum (eq. 23) are all statements about radiance. The runner decodes
the frame once, lets each model act on the linear buffer, and encodes once; values
above 1.0 clip to 255, which is the sensor's saturation.

Stages
------
A frame passes through six stages in physical order, and every model acts in the
stages it belongs to (see :data:`STAGES`): what the surface is made of (wet road,
settled snow), how it is lit (cast shadows), what it reflects (wet-road sky mirror,
the sun's specular lobe), the atmosphere between surface and camera (haze, fog), the
particles nearest the camera (drops, flakes), and the optics (veiling glare, bloom).

Ground-truth masks
------------------
A model's mask marks the pixels its stages changed by at least
:data:`MASK_THRESHOLD` = 8 grey levels (of 255) on any channel of the encoded frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, ClassVar

import cv2
import numpy as np

from simroad._validation import (
    SimroadError,
    check_finite_number,
    check_image,
    check_in_range,
    normalize_rng,
)
from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.camera.render import VehicleBox
from simroad.camera.world import MARKING, SKY

__all__ = [
    "GAMMA",
    "MASK_THRESHOLD",
    "STAGES",
    "FrameState",
    "NoiseContext",
    "NoiseModel",
    "Params",
    "change_mask",
    "fast_exp",
    "flat_ground_camera",
    "gray3",
    "linear_to_srgb",
    "rgb_scalar",
    "run_models",
    "srgb_to_linear",
]

GAMMA = 2.2
MASK_THRESHOLD = 8
STAGES = ("material", "illumination", "reflection", "atmosphere", "particles", "optics")

_DECODE_LUT = ((np.arange(256, dtype=np.float64) / 255.0) ** GAMMA).astype(np.float32)


# ----------------------------------------------------------------- radiometry
def srgb_to_linear(image: np.ndarray) -> np.ndarray:
    """Decode an sRGB frame to linear relative radiance.

    Parameters
    ----------
    image : ndarray, uint8 (H, W, 3) in 0..255, or float32/float64 in [0, 1]

    Returns
    -------
    ndarray, float32, (H, W, 3)
        Linear radiance, 1.0 = white.
    """
    if image.dtype == np.uint8:
        return cv2.LUT(image, _DECODE_LUT)
    return np.power(image.astype(np.float32), GAMMA, dtype=np.float32)


def linear_to_srgb(lin: np.ndarray, dtype: np.dtype | type = np.uint8) -> np.ndarray:
    """Encode linear radiance; values above 1.0 saturate (255 for uint8).

    Parameters
    ----------
    lin : ndarray, float32, (H, W, 3)
        Linear radiance (not modified).
    dtype : numpy dtype
        ``uint8`` (0..255) or a float dtype (0..1).
    """
    x = cv2.log(cv2.max(lin, 1e-7))  # x ** (1/γ) as exp(log(x)/γ): twice as fast as cv2.pow
    x *= np.float32(1.0 / GAMMA)
    x = cv2.exp(x)
    if np.dtype(dtype) == np.uint8:
        return cv2.convertScaleAbs(x, alpha=255.0)
    return np.minimum(x, 1.0).astype(dtype)


def change_mask(before: np.ndarray, after: np.ndarray, threshold: int = MASK_THRESHOLD) -> np.ndarray:
    """Pixels where two uint8 frames differ by ``>= threshold`` on any channel.

    Parameters
    ----------
    before, after : ndarray, uint8, (H, W, 3)

    Returns
    -------
    ndarray, bool, (H, W)
    """
    d = cv2.absdiff(before, after)
    return np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2]) >= threshold


def _as_uint8(image: np.ndarray) -> np.ndarray:
    if image.dtype == np.uint8:
        return image
    return np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)


# -------------------------------------------------------------------- context
@lru_cache(maxsize=8)
def _flat_camera(height: int, width: int) -> PinholeCamera:
    return PinholeCamera(CameraConfig(width=width, height=height))


def flat_ground_camera(height: int, width: int) -> PinholeCamera:
    """The default camera for frames that come without geometry.

    A :class:`~simroad.camera.PinholeCamera` with the default mounting (1.3 m high,
    5 degrees down, 70 degrees horizontal field of view) over a flat ground plane,
    at world pose ``(0, 0, 0)``, i.e. looking along the world x axis. Sizes are
    limited to the camera's 16..1280 x 16..720 pixels; resize larger photographs.
    """
    if not (16 <= width <= 1280 and 16 <= height <= 720):
        raise SimroadError(
            f"image: the flat-ground default camera supports 16..1280 x 16..720 pixels "
            f"(width x height), got {width}x{height}. Resize the image first, or pass "
            f"camera= and depth= for it."
        )
    cam = _flat_camera(int(height), int(width))
    cam.set_pose(0.0, 0.0, 0.0)
    return cam


@dataclass(frozen=True, eq=False)
class NoiseContext:
    """What the weather models may know about one frame besides its pixels.

    Parameters
    ----------
    camera : PinholeCamera, optional
        Camera geometry *with the frame's pose set* (the renderer leaves it so).
        ``None``: :func:`flat_ground_camera` for the frame's size.
    depth : ndarray, float32 (H, W), optional
        Ground distance in metres per pixel, ``inf`` for the sky. ``None``: the
        camera's flat-ground depth.
    material : ndarray, uint8 (H, W), optional
        Material codes of :mod:`simroad.camera.world`. ``None``: every pixel with
        finite depth is treated as road surface.
    vehicles : sequence of VehicleBox
        Other vehicles (they cast shadows).
    ego_speed : float
        Ego speed in m/s, in [-100, 100].
    ego_yaw_rate : float
        Ego yaw rate in rad/s (positive turns towards the ego's right), in [-10, 10].
    dt : float
        Time since the previous frame in s, in (0, 1].
    time_s : float
        Time since the episode start in s, >= 0.
    """

    camera: PinholeCamera | None = None
    depth: np.ndarray | None = None
    material: np.ndarray | None = None
    vehicles: Sequence[VehicleBox] = ()
    ego_speed: float = 0.0
    ego_yaw_rate: float = 0.0
    dt: float = 1.0 / 15.0
    time_s: float = 0.0

    def __post_init__(self) -> None:
        if self.camera is not None and not isinstance(self.camera, PinholeCamera):
            raise SimroadError(
                f"camera: expected a simroad.camera.PinholeCamera or None, got {type(self.camera).__name__}."
            )
        if self.depth is not None:
            _check_plane("depth", self.depth, kinds="f")
        if self.material is not None:
            _check_plane("material", self.material, kinds="u")
        vehicles = tuple(self.vehicles)
        for k, v in enumerate(vehicles):
            if not isinstance(v, VehicleBox):
                raise SimroadError(f"vehicles[{k}]: expected a VehicleBox, got {type(v).__name__}.")
        object.__setattr__(self, "vehicles", vehicles)
        object.__setattr__(self, "ego_speed", check_in_range("ego_speed", self.ego_speed, -100, 100, unit="m/s"))
        object.__setattr__(
            self, "ego_yaw_rate", check_in_range("ego_yaw_rate", self.ego_yaw_rate, -10, 10, unit="rad/s")
        )
        object.__setattr__(self, "dt", check_in_range("dt", self.dt, 0.0, 1.0, unit="s", low_inclusive=False))
        t = check_finite_number("time_s", self.time_s)
        if t < 0:
            raise SimroadError(f"time_s: expected a time >= 0 s, got {t:g}.")
        object.__setattr__(self, "time_s", t)


def _check_plane(name: str, arr: Any, *, kinds: str) -> None:
    if not isinstance(arr, np.ndarray) or arr.ndim != 2 or arr.dtype.kind not in kinds:
        what = "float (H, W) array in metres" if kinds == "f" else "uint8 (H, W) array of material codes"
        got = f"{arr.dtype} array of shape {arr.shape}" if isinstance(arr, np.ndarray) else type(arr).__name__
        raise SimroadError(f"{name}: expected a {what}, got {got}.")
    if kinds == "f" and np.isnan(arr).any():
        raise SimroadError(f"{name}: contains NaN; use inf for pixels that see no surface.")


@dataclass
class FrameState:
    """Everything the stages of one frame share (mutable, one per frame).

    Attributes
    ----------
    lin : ndarray, float32, (H, W, 3)
        The working image in linear radiance; stages modify it in place.
    camera : PinholeCamera
        Camera with the frame's pose.
    depth : ndarray, float32, (H, W)
        Ground distance in m, ``inf`` for the sky.
    material : ndarray, uint8, (H, W) or None
    ground : ndarray, bool, (H, W)
        Pixels that see the ground plane (not sky, not a vehicle).
    ctx : NoiseContext
    sun_visibility : ndarray, float32 (H, W) or None
        Fraction of the sun's disc visible from each ground pixel (set by the
        shadow model; 1 = fully lit).
    sun_optical_depth : float
        Extinction optical depth of the atmosphere along a vertical path to the sun
        (set by fog); the sun's irradiance is scaled by ``exp(-od / sin(elevation))``.
    water_film : float
        Fraction of the road under a smooth water film (set by rain).
    """

    lin: np.ndarray
    camera: PinholeCamera
    depth: np.ndarray
    material: np.ndarray | None
    ground: np.ndarray
    ctx: NoiseContext
    sun_visibility: np.ndarray | None = None
    sun_optical_depth: float = 0.0
    water_film: float = 0.0
    _cache: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.lin.shape[:2]

    @property
    def ground_rows(self) -> slice:
        """Rows that contain ground pixels (a slice; the rest is sky)."""
        if "rows" not in self._cache:
            rows = np.flatnonzero(self.ground.any(axis=1))
            self._cache["rows"] = slice(int(rows[0]), int(rows[-1]) + 1) if len(rows) else slice(0, 0)
        return self._cache["rows"]

    def scene_mean(self) -> np.ndarray:
        """Mean linear radiance per channel of the current image as exposed (values
        clipped at white, as the sensor records them), over every 4th row, (3,)."""
        return np.array(cv2.mean(cv2.min(self.lin[::4], 1.0))[:3], dtype=np.float32)

    def sky_radiance(self) -> np.ndarray:
        """Mean linear radiance of the sky pixels (every 4th row), (3,); white if no
        sky is visible."""
        sky = ~np.isfinite(self.depth[::4]) if self.material is None else self.material[::4] == SKY
        if not sky.any():
            return np.ones(3, dtype=np.float32)
        return np.array(cv2.mean(self.lin[::4], mask=sky.view(np.uint8))[:3], dtype=np.float32)


def _resolve(image: np.ndarray, ctx: NoiseContext) -> tuple[PinholeCamera, np.ndarray, np.ndarray | None, np.ndarray]:
    h, w = image.shape[:2]
    cam = ctx.camera if ctx.camera is not None else flat_ground_camera(h, w)
    if (cam.config.height, cam.config.width) != (h, w):
        raise SimroadError(
            f"camera: its image size {cam.config.width}x{cam.config.height} does not match the "
            f"image's {w}x{h} (width x height). Pass the camera that rendered the frame."
        )
    depth = cam.depth if ctx.depth is None else ctx.depth
    for name, arr in (("depth", depth), ("material", ctx.material)):
        if arr is not None and arr.shape != (h, w):
            raise SimroadError(f"{name}: expected shape {(h, w)} to match the image, got {arr.shape}.")
    depth = depth.astype(np.float32, copy=False)
    material = ctx.material
    if material is None:
        ground = np.isfinite(depth)
    else:
        ground = (material <= MARKING) & np.isfinite(depth)
    return cam, depth, material, ground


# ---------------------------------------------------------------------- models
@dataclass(frozen=True)
class Params:
    """Base of the per-model parameter dataclasses."""

    @classmethod
    def from_severity(cls, severity: float) -> Params:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def is_identity(self) -> bool:
        """True when these parameters leave every frame unchanged."""
        raise NotImplementedError  # pragma: no cover - abstract


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
            raise SimroadError(
                f"params: the {self.name!r} model takes {self.params_type.__name__}, got {type(params).__name__}."
            )
        self.params = params
        self._rng: np.random.Generator | None = None
        self._world = None

    @classmethod
    def from_severity(cls, severity: float) -> NoiseModel:
        """The model with the documented parameters for ``severity`` in [0, 1]."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(cls.params_type.from_severity(s))

    def reset(self, rng: np.random.Generator | int, *, world=None) -> None:
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
            raise SimroadError(f"{self.name}: call reset(rng) before apply(...).")
        return self._rng

    def prepare(self, state: FrameState) -> None:
        """Hook run before the first stage of every frame."""

    def apply(self, image: np.ndarray, ctx: NoiseContext | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Apply this model alone to one frame.

        Returns
        -------
        noisy : ndarray, same shape and dtype as ``image``
        mask : ndarray, bool, (H, W)
            Where the frame changed by at least :data:`MASK_THRESHOLD` grey levels.
        """
        out, masks = run_models([self], image, ctx)
        return out, masks[self.name]


def run_models(
    models: Sequence[NoiseModel], image: np.ndarray, ctx: NoiseContext | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
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
        raise SimroadError(f"ctx: expected a NoiseContext, got {type(ctx).__name__}.")
    h, w = image.shape[:2]
    masks = {m.name: np.zeros((h, w), dtype=bool) for m in models}
    active = [m for m in models if not m.params.is_identity]
    for m in active:
        m._require_reset()
    cam, depth, material, ground = _resolve(image, ctx)
    if not active:
        return image.copy(), masks
    state = FrameState(srgb_to_linear(image), cam, depth, material, ground, ctx)
    for m in active:
        m.prepare(state)
    plan = [(stage, m) for stage in STAGES for m in active if stage in m.stages]
    enc_prev = _as_uint8(image)
    for k, (stage, m) in enumerate(plan):
        getattr(m, stage)(state)
        if k + 1 < len(plan) and plan[k + 1][1] is m:
            continue  # same model again: one mask update covers both stages
        enc = linear_to_srgb(state.lin)
        masks[m.name] |= change_mask(enc_prev, enc)
        enc_prev = enc
    if image.dtype == np.uint8:
        return enc_prev, masks
    return linear_to_srgb(state.lin, image.dtype), masks


# -------------------------------------------------------------- small helpers
def sun_direction_ego(azimuth_rad: float, elevation_rad: float, heading_rad: float) -> np.ndarray:
    """Unit vector towards the sun in the ego frame (X forward, Y right, Z down).

    ``azimuth_rad`` is the world heading angle of the sun's horizontal direction
    (0 = world +x, pi/2 = world +y, the same convention as a vehicle heading).
    """
    phi = azimuth_rad - heading_rad
    ce = math.cos(elevation_rad)
    return np.array([ce * math.cos(phi), ce * math.sin(phi), -math.sin(elevation_rad)])


def smoothstep(x: np.ndarray) -> np.ndarray:
    """Cubic smoothstep of ``x`` clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def fast_exp(x: np.ndarray) -> np.ndarray:
    """``exp(x)`` of a float32 array, with ``x`` clipped at -80 first.

    Below about -87 the result is a float32 denormal, which costs the CPU a
    hundred times more per element; ``exp(-80)`` ≈ 2e-35 is zero for any pixel.
    """
    return cv2.exp(cv2.max(np.asarray(x, dtype=np.float32), -80.0))


def rgb_scalar(value: np.ndarray | float) -> tuple[float, float, float, float]:
    """A per-channel constant as an OpenCV scalar (fast, unlike NumPy broadcasting
    over the channel axis)."""
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,))
    return (float(v[0]), float(v[1]), float(v[2]), 0.0)


def gray3(weight: np.ndarray) -> np.ndarray:
    """A float32 (H, W) map repeated over three channels, (H, W, 3)."""
    return cv2.cvtColor(np.ascontiguousarray(weight, dtype=np.float32), cv2.COLOR_GRAY2RGB)


def material_weights(state: FrameState, table: dict[int, float], default_ground: float) -> np.ndarray:
    """Per-pixel weight (H, W) float32 from a material -> weight table.

    Pixels without material information get ``default_ground`` on the ground and 0
    elsewhere; sky and vehicles get 0 unless listed.
    """
    if state.material is None:
        return np.where(state.ground, np.float32(default_ground), np.float32(0.0)).astype(np.float32)
    return cv2.LUT(state.material, _material_lut(tuple(sorted(table.items()))))


@lru_cache(maxsize=32)
def _material_lut(items: tuple[tuple[int, float], ...]) -> np.ndarray:
    lut = np.zeros(256, dtype=np.float32)
    for code, wgt in items:
        lut[code] = wgt
    lut.flags.writeable = False
    return lut
