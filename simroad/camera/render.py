"""Render what the dashboard camera sees, with exact ground truth.

One ``cv2.warpPerspective`` of the world window per frame for the colour and one
nearest-neighbour warp for the material (hence the road mask); the sky and the
per-pixel ground distance depend only on the mounting and are computed once.
Things with height (the world's scenery and the other vehicles, one
:class:`~simroad.camera.mesh.Mesh` each) are drawn over the ground by the z-buffer
rasteriser of :mod:`simroad.camera._painter` (exact occlusion and depth per pixel,
the flat ground's depth as the initial buffer); every vehicle first darkens the
ground around its footprint (a soft contact shadow, compiled in
:func:`simroad.camera._raster.contact_shadows`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from simroad.camera import _ground_blur, _raster, _sheen
from simroad.camera._painter import NEAR_M, MeshPainter
from simroad.camera.codes import SKY
from simroad.camera.geometry import PinholeCamera
from simroad.camera.mesh import Mesh
from simroad.camera.profile import CameraProfile
from simroad.camera.sky import draw_sky
from simroad.camera.vehicles import VehicleBox, vehicles_mesh
from simroad.camera.window import Window
from simroad.camera.world import WorldRaster
from simroad.errors import InvalidParameterError

__all__ = ["AO_STRENGTH", "CameraRenderer", "Frame"]

#: Ambient occlusion under a vehicle: fraction of the sky light the ground under the
#: car loses ...
AO_STRENGTH = 0.55
#: ... from this far inside the footprint (m), fading to none ...
_AO_INNER_M = 0.25
#: ... this far outside it (m).
_AO_REACH_M = 0.45
#: Scenery is requested this far (m) beyond the visible ground's footprint.
_OBJECT_MARGIN_M = 8.0


_NO_FACES = np.zeros((0, 0), dtype=np.int32)


@dataclass
class Frame:
    """One rendered camera frame.

    Attributes
    ----------
    rgb : ndarray, uint8, (H, W, 3)
    material : ndarray, uint8, (H, W)
        Material codes of :mod:`simroad.camera.world` (road, marking, shoulder,
        roadside, vehicle, sky).
    road_mask : ndarray, bool, (H, W)
        Visible drivable surface (lanes and their markings).
    depth : ndarray, float32, (H, W)
        Horizontal distance in metres from the camera to the surface point each pixel
        sees (ground or face); ``inf`` for sky and beyond range.
    vehicles : list of VehicleBox
    face_id : ndarray, int32, (H, W)
        Index into ``faces`` of the face each pixel sees; -1 for ground and sky.
    faces : Mesh
        The faces that were drawn (of the scenery, then of the vehicles; faces out
        of view, turned away or below a pixel are left out).
    motion_m : float
        The camera's travel during the exposure by which the ground (not the faces)
        is already motion-blurred; 0 for a still frame.
    """

    rgb: np.ndarray
    material: np.ndarray
    road_mask: np.ndarray
    depth: np.ndarray
    vehicles: list[VehicleBox] = field(default_factory=list)
    face_id: np.ndarray = field(default_factory=lambda: _NO_FACES)
    faces: Mesh = field(default_factory=Mesh.empty)
    motion_m: float = 0.0

    def __post_init__(self) -> None:
        if self.face_id is _NO_FACES:
            self.face_id = np.full(self.material.shape, -1, dtype=np.int32)


class CameraRenderer:
    """Renders frames of a :class:`WorldRaster` through a :class:`PinholeCamera`.

    Parameters
    ----------
    camera : PinholeCamera
    world : WorldRaster
    rng : numpy.random.Generator
        Draws the sky (:func:`simroad.camera.sky.draw_sky`).
    profile : CameraProfile, optional
        The daylight it is drawn from (simroad's default when None).
    sky_view : (float, float)
        Range of the ground's sky-view factor (:data:`simroad.camera.sky.SKY_VIEW`).

    Attributes
    ----------
    sky : SkySpec
        The world's sky and daylight, seen at heading 0 so that the sky in the frame
        does not depend on the camera's previous pose.
    """

    def __init__(
        self,
        camera: PinholeCamera,
        world: WorldRaster,
        rng: np.random.Generator,
        *,
        profile: CameraProfile | None = None,
        sky_view: tuple[float, float] = (1.0, 1.0),
    ) -> None:
        self.camera = camera
        self.world = world
        c = camera.config
        self.sky = draw_sky(rng, daylight=profile, sky_view=sky_view)
        sky = _sheen.renderer_sky(camera, self.sky)
        depth = camera.depth
        # Aerial perspective over the last 40 % of the range hides the cut-off.
        fade_start = 0.6 * c.max_range_m
        with np.errstate(invalid="ignore"):
            t = np.clip((depth - fade_start) / (c.max_range_m - fade_start), 0.0, 1.0)
        t = np.where(camera.ground_valid, t * t * (3 - 2 * t), 0.0).astype(np.float32)
        rows = np.nonzero((t > 0).any(axis=1))[0]
        self._fade_rows = slice(int(rows.min()), int(rows.max()) + 1) if len(rows) else slice(0, 0)
        self._fade_alpha = t[self._fade_rows, :, None]
        haze = sky[max(0, min(c.height - 1, int(round(camera.horizon_row))))].mean(axis=0)
        self._haze = haze.astype(np.float32)
        self._sky_rgb = np.clip(sky, 0, 255).astype(np.uint8)
        self._sky = ~camera.ground_valid
        # Rows [0, r0) are all sky; rows [r0, r1) mix sky and ground; below r1 all ground.
        rows_any = np.nonzero(camera.ground_valid.any(axis=1))[0]
        rows_all = np.nonzero(camera.ground_valid.all(axis=1))[0]
        self._r0 = int(rows_any[0]) if len(rows_any) else c.height
        self._r1 = int(rows_all[0]) if len(rows_all) else c.height
        self._mixed_sky = self._sky[self._r0 : self._r1]
        self._shift = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, float(self._r0)], [0.0, 0.0, 1.0]])
        self._bands = _all_bands(_mip_bands(camera, self._r0), self._r0, c.height)
        # Each row's forward ground distance (constant along a row) and the farthest
        # column from the principal point: the ground's motion blur per row.
        centre = min(max(int(round(camera.K[0, 2])), 0), c.width - 1)
        with np.errstate(invalid="ignore"):
            forward_m = np.where(camera.ground_valid[:, centre], camera.depth[:, centre], np.nan)
        self._row_blur = _ground_blur.RowBlur(
            forward_m,
            horizon_row=float(camera.horizon_row),
            half_width_px=max(float(camera.K[0, 2]), c.width - float(camera.K[0, 2])),
            first_ground_row=self._r0,
        )
        # Footprint of the visible ground in the ego frame, for the window request.
        g = camera._ego_ground[camera.ground_valid]
        hull = cv2.convexHull(g.astype(np.float32)).reshape(-1, 2)
        self._footprint = np.vstack([hull, [[c.forward_offset_m, 0.0]]]).astype(float)
        self._painter = MeshPainter(camera, haze=self._haze)
        self._ground = np.ascontiguousarray(camera.ground_valid)
        eg = np.nan_to_num(camera._ego_ground, nan=0.0)
        self._gx, self._gy = np.ascontiguousarray(eg[..., 0]), np.ascontiguousarray(eg[..., 1])
        self._alpha = np.empty((c.height - self._r0, c.width), np.uint8)  # scratch: the warped road SDF
        self._band = np.empty((c.height - self._r0, c.width, 4), np.uint8)  # scratch: a warped band of colour
        # The sky the road reflects, times the world's gloss (nothing to add without gloss).
        gloss = self.world.palette.sheen
        self._sheen = np.float32(gloss) * _sheen.renderer_sheen(camera, self.sky, self._r0) if gloss > 0.0 else None

    def footprint_world(self) -> np.ndarray:
        """World (x, y) of the visible-ground footprint polygon for the current pose."""
        x, y, h = self.camera.pose
        ch, sh = math.cos(h), math.sin(h)
        f = self._footprint
        return np.column_stack([x + ch * f[:, 0] - sh * f[:, 1], y + sh * f[:, 0] + ch * f[:, 1]])

    def render(
        self, pose: tuple[float, float, float], vehicles: Sequence[VehicleBox] = (), *, motion_m: float = 0.0
    ) -> Frame:
        """Render the frame seen from ego ``pose = (x, y, heading)``.

        ``motion_m`` is the distance the camera travels along its heading during the
        exposure (the sensor's :meth:`~simroad.camera.sensor.Sensor.travel_m`): the
        ground is motion-blurred by it, in the world's texture
        (:mod:`simroad.camera._ground_blur`); 0 renders a still frame.
        """
        motion_m = float(motion_m)
        if not (math.isfinite(motion_m) and motion_m >= 0.0):
            raise InvalidParameterError(f"motion_m: expected a distance >= 0 in metres, got {motion_m!r}.")
        cam = self.camera
        cam.set_pose(*pose)
        fp = self.footprint_world()
        lo, hi = fp.min(axis=0), fp.max(axis=0)
        # The window reaches two tiles ahead: driving forward re-assembles it seldom.
        lead = 2.0 * self.world.tile_m
        win = self.world.window(*lo, *hi, lead=(lead * math.cos(pose[2]), lead * math.sin(pose[2])))
        c = cam.config
        r0 = self._r0
        # Rows above r0 are sky; the ground's warps write every pixel of the rows below.
        rgb = np.empty((c.height, c.width, 3), dtype=np.uint8)
        rgb[:r0] = self._sky_rgb[:r0]
        material = np.empty((c.height, c.width), dtype=np.uint8)
        material[:r0] = SKY
        road = np.empty((c.height, c.width), dtype=bool)
        road[:r0] = False
        if r0 < c.height:
            self._draw_ground(win, pose, motion_m, rgb, material, road)
        depth = cam.depth.copy()  # each frame its own (callers keep them)
        ground_vehicles = self._in_view(vehicles)
        m, M_ = lo - _OBJECT_MARGIN_M, hi + _OBJECT_MARGIN_M
        parts = [self.world.objects(m[0], m[1], M_[0], M_[1]), vehicles_mesh(ground_vehicles)]
        face_id, faces = self._painter.paint_parts(parts, rgb, material, depth, road=road)
        if ground_vehicles:  # on the ground the faces leave in view
            self._contact_shadows(rgb, face_id, ground_vehicles)
        if not len(faces):
            face_id = _NO_FACES
        return Frame(rgb, material, road, depth, list(vehicles), face_id=face_id, faces=faces, motion_m=motion_m)

    # ------------------------------------------------------------ the ground
    def _draw_ground(
        self,
        win: Window,
        pose: tuple[float, float, float],
        motion_m: float,
        rgb: np.ndarray,
        material: np.ndarray,
        road: np.ndarray,
    ) -> None:
        """Rows ``r0`` on of colour, material and road mask: the window warped, the
        mixed rows' sky restored where they look beyond the range."""
        c = self.camera.config
        r0, r1 = self._r0, self._r1
        # Warp only the rows that can see ground (destination offset by r0).
        M = win.texel_from_world @ self.camera.H_world_from_image @ self._shift
        size = (c.width, c.height - r0)
        flags = cv2.WARP_INVERSE_MAP
        alpha = cv2.warpPerspective(
            win.alpha, M, size, dst=self._alpha, flags=cv2.INTER_LINEAR | flags, borderMode=cv2.BORDER_REPLICATE
        )
        np.greater_equal(alpha, 128, out=road[r0:])  # exact GT from the full-resolution SDF
        cv2.warpPerspective(
            win.material, M, size, dst=material[r0:], flags=cv2.INTER_NEAREST | flags, borderMode=cv2.BORDER_REPLICATE
        )
        self._colour_bands(win, M, pose, motion_m, rgb)
        if self._sheen is not None:
            _sheen.add_sheen(rgb, road[r0:], self._sheen)
        fr = self._fade_rows
        if fr.stop > fr.start:
            _raster.fade(rgb[fr], self._fade_alpha, self._haze)
        if r1 > r0:  # restore the sky where mixed rows look beyond the range
            mixed = self._mixed_sky
            np.copyto(rgb[r0:r1], self._sky_rgb[r0:r1], where=mixed[..., None])
            material[r0:r1][mixed] = SKY
            road[r0:r1][mixed] = False

    def _colour_bands(
        self, win: Window, M: np.ndarray, pose: tuple[float, float, float], motion_m: float, rgb: np.ndarray
    ) -> None:
        """The ground's colour in rows ``r0`` on, band by band of rows from the mip level
        that fits them, the rows that blur by half a pixel or more from the blurred
        texture."""
        c = self.camera.config
        r0 = self._r0
        blur = self._ground_blur(motion_m) if motion_m > 0.0 else None
        start = blur[0] if blur is not None else c.height
        heading = (math.cos(pose[2]), math.sin(pose[2]))
        for level, a, b in self._bands:  # colour from the mip level that fits the rows
            SM = _level_scale(level) @ M  # (S @ M) @ T, as S @ M @ T evaluates
            for lo, hi in ((a, min(b, start)), (max(a, start), b)):
                if hi <= lo:
                    continue
                Ma = SM @ _row_shift(lo - r0)
                dst = rgb[lo:hi]
                # A mip level's texel is the pixel's footprint (that is how the level
                # is chosen): a smear under half of it is lost in the pixel.
                texels = motion_m * 2.0**-level / win.texel_m
                if lo >= start and blur is not None and (level == 0 or texels >= 0.5):
                    self._warp_blurred(win, level, Ma, dst, motion_m, heading)
                else:
                    band = cv2.warpPerspective(
                        win.level(level),
                        Ma,
                        (c.width, hi - lo),
                        dst=self._band[: hi - lo],
                        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                        borderMode=cv2.BORDER_REPLICATE,
                    )
                    cv2.cvtColor(band, cv2.COLOR_RGBA2RGB, dst=dst)

    # ------------------------------------------------------- motion blur
    def _ground_blur(self, motion_m: float) -> tuple[int, np.ndarray] | None:
        """First row whose ground blurs by half a pixel or more, and each row's longest
        ground blur in pixels; None when no row does."""
        start, length = self._row_blur(motion_m)
        return (start, length) if start < self.camera.config.height else None

    def _warp_blurred(
        self,
        win,
        level: int,
        Ma: np.ndarray,
        dst: np.ndarray,
        motion_m: float,
        heading: tuple[float, float],
    ) -> None:
        """Warp the rows of ``dst`` from a motion-blurred crop of mip ``level``."""
        src = win.level(level)
        h, w = dst.shape[:2]
        corners = np.array([[0.0, 0.0, 1.0], [w - 1.0, 0.0, 1.0], [0.0, h - 1.0, 1.0], [w - 1.0, h - 1.0, 1.0]])
        t = corners @ Ma.T
        t = t[:, :2] / t[:, 2:3]
        scale = 2.0**-level / win.texel_m
        shift = (-motion_m * heading[0] * scale, -motion_m * heading[1] * scale)
        margin = abs(shift[0]) + abs(shift[1]) + 3.0
        tx, ty = t.T.tolist()
        tx0, ty0, tx1, ty1 = min(tx), min(ty), max(tx), max(ty)
        sh, sw = src.shape[:2]
        x0 = min(max(math.floor(tx0 - margin), 0), sw - 1)
        x1 = min(max(math.ceil(tx1 + margin) + 1, x0 + 1), sw)
        y0 = min(max(math.floor(ty0 - margin), 0), sh - 1)
        y1 = min(max(math.ceil(ty1 + margin) + 1, y0 + 1), sh)
        crop = _ground_blur.box_blur_texture(src[y0:y1, x0:x1], shift)
        offset = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
        band = cv2.warpPerspective(
            crop,
            offset @ Ma,
            (w, h),
            dst=self._band[:h],
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REPLICATE,
        )
        cv2.cvtColor(band, cv2.COLOR_RGBA2RGB, dst=dst)

    # ------------------------------------------------------- things with height
    def _in_view(self, vehicles: Sequence[VehicleBox]) -> list[VehicleBox]:
        """The vehicles that may be seen: within range and not wholly behind the camera."""
        if not vehicles:
            return []
        cx, cy = (float(v) for v in self.camera.position_world)  # Python floats: no numpy scalars in the loop
        h = self.camera.pose[2]
        ch, sh = math.cos(h), math.sin(h)
        r = self.camera.config.max_range_m
        out = []
        for v in vehicles:
            dx, dy = v.x - cx, v.y - cy
            reach = 0.5 * math.hypot(v.length, v.width) + _AO_REACH_M
            if dx * ch + dy * sh > -reach and math.hypot(dx, dy) < r + reach:
                out.append(v)
        return out

    def _contact_shadows(self, rgb: np.ndarray, face_id: np.ndarray, vehicles: Sequence[VehicleBox]) -> None:
        """Darken the ground under and around each vehicle (ambient occlusion).

        The occlusion is a smooth function of the signed ground distance ``sd`` (m) to
        the vehicle's footprint: ``AO_STRENGTH`` from 0.25 m under the car, 0.7 of it at
        the footprint's edge, none 0.45 m outside (where footprints meet, the
        strongest). Material and road mask are untouched (the road is still road in a
        shadow). Only the ground pixels no face hides (``face_id`` < 0) in the screen
        box of each grown footprint are visited
        (:func:`simroad.camera._raster.contact_shadows`).
        """
        cam = self.camera
        k = cam.K
        x, y, h = cam.pose
        v = np.array([[b.x, b.y, b.heading, b.length / 2, b.width / 2] for b in vehicles])
        corners, boxes = _raster.footprints(
            v, np.cos(v[:, 2]), np.sin(v[:, 2]), _AO_REACH_M, x, y, h, math.cos(h), math.sin(h)
        )
        M, o = self._painter._affine()
        cam_v = np.array([k[0, 0], k[1, 1], k[0, 2], k[1, 2], NEAR_M])
        _raster.contact_shadows(
            rgb,
            self._ground,
            face_id,
            self._gx,
            self._gy,
            boxes,
            corners @ M + o,
            cam_v,
            AO_STRENGTH,
            _AO_INNER_M,
            _AO_REACH_M,
        )


@functools.cache
def _level_scale(level: int) -> np.ndarray:
    """Level-0 texel coordinates to mip level ``level``'s (read-only)."""
    k = 2.0**-level
    S = np.array([[k, 0.0, 0.5 * k - 0.5], [0.0, k, 0.5 * k - 0.5], [0.0, 0.0, 1.0]])
    S.flags.writeable = False
    return S


@functools.lru_cache(maxsize=4096)
def _row_shift(rows: int) -> np.ndarray:
    """A band's destination rows to the warp's: ``rows`` rows down (read-only)."""
    T = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, float(rows)], [0.0, 0.0, 1.0]])
    T.flags.writeable = False
    return T


def _all_bands(mip: list[tuple[int, int, int]], r0: int, height: int) -> list[tuple[int, int, int]]:
    """Row bands ``(level, first_row, end_row)`` covering rows ``r0 .. height``: the mip
    bands and, between them, level 0."""
    out, v = [], r0
    for level, a, b in sorted(mip, key=lambda band: band[1]):
        if a > v:
            out.append((0, v, a))
        out.append((level, a, b))
        v = b
    if v < height:
        out.append((0, v, height))
    return out


def _mip_bands(camera: PinholeCamera, r0: int, max_level: int = 3) -> list[tuple[int, int, int]]:
    """Row bands ``(level, first_row, end_row)`` whose colour comes from mip level >= 1.

    A pixel row at ground distance d covers about ``d**2 / (f h)`` metres in depth and
    ``d / f`` across; the level is log2 of the geometric mean of both footprints in
    texels, so that a pixel averages the ground it sees, as a camera pixel does.
    """
    c = camera.config
    col = c.width // 2
    d = camera.depth[:, col].astype(np.float64)
    levels = np.zeros(c.height, dtype=int)
    for v in range(r0, c.height - 1):
        if not (np.isfinite(d[v]) and np.isfinite(d[v + 1])):
            continue
        along = abs(d[v] - d[v + 1]) / c.texel_m
        across = d[v] / camera.K[0, 0] / c.texel_m
        levels[v] = int(np.clip(np.round(np.log2(max(1e-9, math.sqrt(along * across)))), 0, max_level))
    bands, v = [], r0
    while v < c.height:
        w = v
        while w < c.height and levels[w] == levels[v]:
            w += 1
        if levels[v] > 0:
            bands.append((int(levels[v]), v, w))
        v = w
    return bands
