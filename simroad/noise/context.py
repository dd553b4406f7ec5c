"""What a weather model knows about one frame: its context and the per-frame state.

:class:`NoiseContext` is what a caller passes with a frame (camera, depth, materials,
vehicles, ego motion); :class:`FrameState` is what the stages of one frame share (the
linear working image and the facts models hand each other, such as the sun's
visibility or the rain's water film).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import cv2
import numpy as np

from simroad.camera.codes import IS_GROUND, SKY
from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.camera.mesh import Mesh
from simroad.camera.vehicles import VehicleBox
from simroad.core.validation import check_finite_number, check_in_range
from simroad.errors import InvalidParameterError

__all__ = ["FrameState", "NoiseContext", "flat_ground_camera", "resolve_frame"]


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
        raise InvalidParameterError(
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
    face_id : ndarray, int32 (H, W), optional
        Index into ``faces`` of the object face each pixel sees, -1 where it sees
        no face (ground, sky). Given together with ``faces``.
    faces : Mesh, optional
        The faces the renderer drew (:class:`simroad.camera.mesh.Mesh`); the shadow
        model shades them by their orientation to the sun.
    motion_m : float
        Distance (m, >= 0) the camera travels during the exposure; the renderer has
        motion-blurred the ground by it (``Frame.motion_m``), and what a model draws
        on the ground (the cast shadows) is smeared alike. 0: a still frame.
    """

    camera: PinholeCamera | None = None
    depth: np.ndarray | None = None
    material: np.ndarray | None = None
    vehicles: Sequence[VehicleBox] = ()
    ego_speed: float = 0.0
    ego_yaw_rate: float = 0.0
    dt: float = 1.0 / 15.0
    time_s: float = 0.0
    face_id: np.ndarray | None = None
    faces: Mesh | None = None
    motion_m: float = 0.0

    def __post_init__(self) -> None:
        if self.camera is not None and not isinstance(self.camera, PinholeCamera):
            raise InvalidParameterError(
                f"camera: expected a simroad.camera.PinholeCamera or None, got {type(self.camera).__name__}."
            )
        if self.depth is not None:
            _check_plane("depth", self.depth, kinds="f")
        if self.material is not None:
            _check_plane("material", self.material, kinds="u")
        if isinstance(self.vehicles, (str, bytes)) or not isinstance(self.vehicles, Iterable):
            raise InvalidParameterError(
                f"vehicles: expected a sequence of VehicleBox (the renderer's Frame.vehicles), "
                f"got {type(self.vehicles).__name__}."
            )
        vehicles = tuple(self.vehicles)
        for k, v in enumerate(vehicles):
            if not isinstance(v, VehicleBox):
                raise InvalidParameterError(f"vehicles[{k}]: expected a VehicleBox, got {type(v).__name__}.")
        object.__setattr__(self, "vehicles", vehicles)
        object.__setattr__(self, "ego_speed", check_in_range("ego_speed", self.ego_speed, -100, 100, unit="m/s"))
        object.__setattr__(
            self, "ego_yaw_rate", check_in_range("ego_yaw_rate", self.ego_yaw_rate, -10, 10, unit="rad/s")
        )
        object.__setattr__(self, "dt", check_in_range("dt", self.dt, 0.0, 1.0, unit="s", low_inclusive=False))
        t = check_finite_number("time_s", self.time_s)
        if t < 0:
            raise InvalidParameterError(f"time_s: expected a time >= 0 s, got {t:g}.")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "motion_m", check_in_range("motion_m", self.motion_m, 0.0, 100.0, unit="m"))
        _check_faces(self.face_id, self.faces)


def _check_faces(face_id: Any, faces: Any) -> None:
    if (face_id is None) != (faces is None):
        given, missing = ("face_id", "faces") if faces is None else ("faces", "face_id")
        raise InvalidParameterError(
            f"{missing}: {given} was given without {missing}; pass both (the renderer's Frame has them) or neither."
        )
    if faces is None:
        return
    if not isinstance(faces, Mesh):
        raise InvalidParameterError(f"faces: expected a simroad.camera.mesh.Mesh, got {type(faces).__name__}.")
    _check_plane("face_id", face_id, kinds="i")
    if face_id.size and (int(face_id.max()) >= len(faces) or int(face_id.min()) < -1):
        raise InvalidParameterError(
            f"face_id: expected indices in -1..{len(faces) - 1} (the faces of the mesh), "
            f"got values in {int(face_id.min())}..{int(face_id.max())}."
        )


def _check_plane(name: str, arr: Any, *, kinds: str) -> None:
    if not isinstance(arr, np.ndarray) or arr.ndim != 2 or arr.dtype.kind not in kinds:
        what = {
            "f": "float (H, W) array in metres",
            "u": "uint8 (H, W) array of material codes",
            "i": "int32 (H, W) array of face indices",
        }[kinds]
        got = f"{arr.dtype} array of shape {arr.shape}" if isinstance(arr, np.ndarray) else type(arr).__name__
        raise InvalidParameterError(f"{name}: expected a {what}, got {got}.")
    if kinds == "f" and not (arr >= 0).all():  # one pass: NaN and negative distances both fail it
        if np.isnan(arr).any():
            raise InvalidParameterError(f"{name}: contains NaN; use inf for pixels that see no surface.")
        raise InvalidParameterError(
            f"{name}: contains negative distances (down to {float(arr.min()):g} m); expected distances >= 0 m, "
            "inf for pixels that see no surface."
        )


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
    sky_clear : float
        How far the sky has cleared for the sun, in [0, 1] (set by the shadow and
        glare models; 0 = the world's overcast sky).
    unmasked : ndarray, bool, (H, W) or None
        Pixels whose change in the current stage is the sky clearing, not noise: the
        runner leaves them out of that stage's noise mask.
    covered : ndarray, bool, (H, W) or None
        Pixels the current stage's model covers (drops and the wiper on the
        windscreen), which belong in its noise mask whether or not they changed by the
        threshold: the runner adds them to that stage's mask.
    touched : ndarray, bool, (H, W) or None
        Set by a stage that changed ``lin`` at these pixels only (every other value
        left bit for bit as it was): the runner then encodes these pixels alone. Only
        for a model with one stage in the frame.
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
    sky_clear: float = 0.0
    unmasked: np.ndarray | None = None
    covered: np.ndarray | None = None
    touched: np.ndarray | None = None
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
        return np.array(cv2.mean(cv2.min(self.lin[::4], 1.0))[:3], dtype=np.float32)  # type: ignore[call-overload,unused-ignore]  # OpenCV's stubs omit scalar operands

    def sky_radiance(self) -> np.ndarray:
        """Mean linear radiance of the sky pixels (every 4th row), (3,); white if no
        sky is visible."""
        sky = ~np.isfinite(self.depth[::4]) if self.material is None else self.material[::4] == SKY
        if not sky.any():
            return np.ones(3, dtype=np.float32)
        return np.array(cv2.mean(self.lin[::4], mask=sky.view(np.uint8))[:3], dtype=np.float32)


def resolve_frame(
    image: np.ndarray, ctx: NoiseContext
) -> tuple[PinholeCamera, np.ndarray, np.ndarray | None, np.ndarray]:
    """The frame's camera, depth (float32), material map and ground mask (bool (H, W)).

    Fills in what ``ctx`` leaves out (:func:`flat_ground_camera`, the camera's
    flat-ground depth) and checks that every plane matches the image's size.
    """
    h, w = image.shape[:2]
    cam = ctx.camera if ctx.camera is not None else flat_ground_camera(h, w)
    if (cam.config.height, cam.config.width) != (h, w):
        raise InvalidParameterError(
            f"camera: its image size {cam.config.width}x{cam.config.height} does not match the "
            f"image's {w}x{h} (width x height). Pass the camera that rendered the frame."
        )
    depth = cam.depth if ctx.depth is None else ctx.depth
    for name, arr in (("depth", depth), ("material", ctx.material), ("face_id", ctx.face_id)):
        if arr is not None and arr.shape != (h, w):
            raise InvalidParameterError(f"{name}: expected shape {(h, w)} to match the image, got {arr.shape}.")
    depth = depth.astype(np.float32, copy=False)
    material = ctx.material
    if material is None:
        ground = np.isfinite(depth)
    else:
        ground = IS_GROUND[material] & np.isfinite(depth)
    return cam, depth, material, ground
