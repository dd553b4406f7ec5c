"""The drops on the glass: their state, the bank of their sprites, and drawing them.

For :mod:`simroad.noise.windscreen`. Each drop has a glass position (m), a contact
radius (m), the pixel its image is centred on and the id of its
:class:`~simroad.noise._glass.Sprite` in a :class:`SpriteBank`, chosen when it forms
(-1 when its image is too small to draw). A sprite depends only on the drop's image
half-axes and blur, quantised (0.25 px, aspect 0.05), so a bank of a few hundred
sprites serves a whole episode: adding drops is a few vectorised lookups, and a frame
is one compiled pass over the drops' sprite pixels
(:func:`simroad.noise._drops_kernel.splat_drops`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from simroad.noise._drops_kernel import splat_drops
from simroad.noise._glass import GlassView, Sprite, drop_sprite

__all__ = ["DropField", "SpriteBank", "draw_drops", "draw_drops_reference", "scene_low_pass"]

_FIELDS = ("du", "dv", "alpha", "w_scene", "src_du", "src_dv")
_STEP = 1.1  # sprites are quantised in steps of 10 %
_LOG_STEP = float(np.log(_STEP))
_TAN_20 = float(np.tan(np.radians(20.0)))


def _blur_code(blur: np.ndarray) -> np.ndarray:
    """Blur diameters (px) in steps of 10 % from 0.5 px (code 0: below 0.5 px, no blur)."""
    q = np.rint(np.log(np.maximum(blur, 0.5) / 0.5) / _LOG_STEP) + 1
    return np.where(blur < 0.5, 0, q).astype(np.int64)


class SpriteBank:
    """The sprites of one camera behind one glass, packed end to end, by quantised key.

    A sprite's key is its image half-width and its blur, each in steps of 10 %; its
    aspect (the glass's foreshortening) is the median of the view's pixels with that
    blur: both follow from the distance to the glass, so they vary together.

    Parameters
    ----------
    view : GlassView
    contact_angle_deg : float
    """

    def __init__(self, view: GlassView, contact_angle_deg: float) -> None:
        self.fx = float(view.fx)
        self.contact_angle_deg = float(contact_angle_deg)
        qb = _blur_code(view.blur.ravel())
        #: Each pixel's quantised blur (flat): half of a new drop's key in one lookup.
        self.blur_code = qb
        cos_inc = view.cos_inc.ravel()
        self._aspect = {int(q): float(np.median(cos_inc[qb == q])) for q in np.unique(qb)}
        self._table = np.full(0, -1, np.int32)  # quantised key -> sprite id, -1: not made yet
        self.start = np.zeros(0, np.int64)
        self.length = np.zeros(0, np.int64)
        self.uniform = np.zeros(0, np.uint8)
        self.arrays: dict[str, np.ndarray] = {
            k: np.zeros(0, np.int32 if k in ("du", "dv") else np.float32) for k in _FIELDS
        }

    def __len__(self) -> int:
        return len(self.start)

    def ids(self, rx: np.ndarray, blur: np.ndarray) -> np.ndarray:
        """Sprite ids (int32) for image half-widths ``rx`` (px) and blur diameters (px);
        sprites not yet in the bank are made and added."""
        return self.ids_coded(rx, _blur_code(blur))

    def ids_coded(self, rx: np.ndarray, blur_code: np.ndarray) -> np.ndarray:
        """:meth:`ids` with the blur already quantised (e.g. ``blur_code[pixel]``)."""
        qr = np.rint(np.log(np.clip(rx, 0.05, 1e4) / 0.05) / _LOG_STEP).astype(np.int64)
        code = qr * 256 + blur_code
        if code.max() >= len(self._table):
            self._table = np.concatenate([self._table, np.full(int(code.max()) + 1 - len(self._table), -1, np.int32)])
        sid = self._table[code]
        if (sid < 0).any():
            new = np.unique(code[sid < 0]).tolist()
            self._table[new] = len(self.start) + np.arange(len(new))
            self._extend([self._sprite(c) for c in new])
            sid = self._table[code]
        return sid

    def _sprite(self, code: int) -> Sprite:
        q_r, q_b = divmod(code, 256)
        rx = 0.05 * _STEP**q_r
        blur = 0.0 if q_b == 0 else 0.5 * _STEP ** (q_b - 1)
        aspect = self._aspect.get(q_b, 1.0)
        return drop_sprite(rx, max(0.1, rx * aspect), blur, self.fx, self.contact_angle_deg)

    def _extend(self, sprites: list[Sprite]) -> None:
        lengths = np.array([len(s.du) for s in sprites], np.int64)
        first = len(self.arrays["du"]) + np.concatenate([[0], np.cumsum(lengths)[:-1]])
        self.start = np.concatenate([self.start, first])
        self.length = np.concatenate([self.length, lengths])
        self.uniform = np.concatenate([self.uniform, np.array([s.uniform for s in sprites], np.uint8)])
        self.arrays = {k: np.concatenate([self.arrays[k], *(getattr(s, k) for s in sprites)]) for k in _FIELDS}

    def packed(self) -> tuple[np.ndarray, ...]:
        """``(start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv)`` for the kernel."""
        return (self.start, self.length, self.uniform, *(self.arrays[k] for k in _FIELDS))


@dataclass
class DropField:
    """The drops on the glass, one entry per drop in each array.

    Attributes
    ----------
    gx, gy : ndarray float64
        Glass coordinates, m.
    radius : ndarray float64
        Contact radius, m.
    u, v : ndarray int32
        Pixel the drop's image is centred on.
    sprite : ndarray int32
        Its sprite in the bank, -1 if not drawn.
    ident : ndarray int64
        A number per drop, unique within the episode (in order of arrival).
    """

    gx: np.ndarray = field(default_factory=lambda: np.empty(0))
    gy: np.ndarray = field(default_factory=lambda: np.empty(0))
    radius: np.ndarray = field(default_factory=lambda: np.empty(0))
    u: np.ndarray = field(default_factory=lambda: np.empty(0, np.int32))
    v: np.ndarray = field(default_factory=lambda: np.empty(0, np.int32))
    sprite: np.ndarray = field(default_factory=lambda: np.empty(0, np.int32))
    ident: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    _arrivals: int = 0

    def __len__(self) -> int:
        return len(self.radius)

    def coverage(self, view_area_m2: float) -> float:
        """Fraction of the glass in view the drops cover (contact areas; overlaps counted twice)."""
        return float(np.pi * np.sum(self.radius**2) / max(view_area_m2, 1e-12))

    def add(self, view: GlassView, bank: SpriteBank, pixel: np.ndarray, radius: np.ndarray, *, min_px: float) -> None:
        """Add drops of contact radii ``radius`` (m) on the glass seen by the centres of
        the pixels ``pixel`` (flat indices)."""
        if len(radius) == 0:
            return
        vi, ui = (a.astype(np.int32) for a in np.divmod(pixel, view.config.width))
        gx, gy = view.gx.ravel()[pixel].astype(float), view.gy.ravel()[pixel].astype(float)
        rx = view.fx * radius / view.dist.ravel()[pixel]
        sprite = np.full(len(radius), -1, np.int32)
        drawn = rx >= min_px
        if drawn.any():
            sprite[drawn] = bank.ids_coded(rx[drawn], bank.blur_code[pixel[drawn]])
        self.gx = np.concatenate([self.gx, gx])
        self.gy = np.concatenate([self.gy, gy])
        self.radius = np.concatenate([self.radius, radius])
        self.u = np.concatenate([self.u, ui])
        self.v = np.concatenate([self.v, vi])
        self.sprite = np.concatenate([self.sprite, sprite])
        self.ident = np.concatenate([self.ident, self._arrivals + np.arange(len(radius))])
        self._arrivals += len(radius)

    def keep(self, alive: np.ndarray) -> None:
        """Keep only the drops where ``alive`` (bool, one per drop) is True."""
        if alive.all():
            return
        for name in ("gx", "gy", "radius", "u", "v", "sprite", "ident"):
            setattr(self, name, getattr(self, name)[alive])

    def move(self, view: GlassView, moving: np.ndarray, dgy: np.ndarray) -> None:
        """Slide the ``moving`` drops (bool mask) by ``dgy`` m up the glass; drops whose
        centre leaves the image are gone (a running drop keeps its sprite). The numpy
        reference the compiled :func:`~simroad.noise._drops_kernel.advance_drops` is
        tested against (the model runs that)."""
        if not moving.any():
            return
        self.gy[moving] += dgy[moving]
        u, v = view.glass_to_pixel(self.gx[moving], self.gy[moving])
        w, h = view.config.width, view.config.height
        out = np.zeros(len(self), bool)
        out[moving] = (u < -0.5) | (u > w - 0.5) | (v < -0.5) | (v > h - 0.5)
        self.u[moving] = np.clip(np.rint(u), 0, w - 1).astype(np.int32)
        self.v[moving] = np.clip(np.rint(v), 0, h - 1).astype(np.int32)
        self.keep(~out)


def scene_low_pass(lin: np.ndarray, factor: int, fx: float) -> tuple[np.ndarray, np.ndarray]:
    """What a defocused drop's minified view can resolve: the frame reduced by ``factor``
    (float32 (H/factor, W/factor, 3)), and that averaged over ±20 degrees (``fx`` px of
    focal length), the mean view of a tiny drop.

    The reduction is the mean of each block (``INTER_AREA``), or, for blocks of 4 px or
    less, of each block's central 2x2 pixels (``INTER_LINEAR``: six times faster at
    320x180, and the drops blur it further)."""
    h, w = lin.shape[:2]
    if factor <= 1:
        small = np.ascontiguousarray(lin)
    else:
        how = cv2.INTER_LINEAR if factor <= 4 else cv2.INTER_AREA
        small = cv2.resize(lin, (max(1, w // factor), max(1, h // factor)), interpolation=how)
    k = 2 * round(fx * _TAN_20 / factor) + 1
    wide = cv2.blur(
        small, (min(k, 2 * small.shape[1] + 1), min(k, 2 * small.shape[0] + 1)), borderType=cv2.BORDER_REPLICATE
    )
    return small, wide


def draw_drops(
    lin: np.ndarray,
    drops: DropField,
    bank: SpriteBank,
    *,
    rim: float,
    factor: int,
    touched: np.ndarray | None = None,
) -> np.ndarray:
    """Composite the drops over the linear frame ``lin`` (float32 (H, W, 3), C-contiguous, in place).

    Each drop pixel, in order of arrival: ``I ← (1 − α)·I + w·scene(src) + (α − w)·rim·mean``
    with ``α`` the drop's defocused coverage of the aperture, ``w`` its part that carries
    the refracted scene, ``scene`` the frame reduced by ``factor`` and ``mean`` the drop's
    whole view averaged (:func:`scene_low_pass`), both sampled bilinearly; a ``uniform``
    sprite shows its mean view throughout (:mod:`simroad.noise._drops_kernel`).

    ``touched`` (bool (H, W), optional) is set at every pixel written.

    Returns
    -------
    ndarray bool (H, W)
        Where a drop covers at least a tenth of the lens's aperture
        (``α >= COVERED``, :data:`simroad.noise._drops_kernel.COVERED`).
    """
    h, w = lin.shape[:2]
    covered = np.zeros(h * w, bool)
    if (drops.sprite >= 0).any():
        small, wide = scene_low_pass(lin, factor, bank.fx)
        written = np.zeros(h * w, bool) if touched is None else touched.reshape(-1)
        packed = (drops.u, drops.v, drops.sprite)
        splat_drops(lin, small, wide, factor, packed, bank.packed(), float(rim), covered, written)
    return covered.reshape(h, w)


def _bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear samples (N, 3) of ``image`` at ``(x, y)``, the border replicated."""
    h, w = image.shape[:2]
    x, y = np.clip(x, 0.0, w - 1.0), np.clip(y, 0.0, h - 1.0)
    x0, y0 = x.astype(int), y.astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    return top * (1 - fy) + (image[y1, x0] * (1 - fx) + image[y1, x1] * fx) * fy


def draw_drops_reference(lin: np.ndarray, drops: DropField, bank: SpriteBank, *, rim: float, factor: int) -> None:
    """:func:`draw_drops` in numpy (one drop at a time, float64 bilinear samples): the
    reference the compiled kernel is tested against."""
    start, length, uniform, du, dv, alpha, w_scene, src_du, src_dv = bank.packed()
    small, wide = scene_low_pass(lin, factor, bank.fx)
    h, w = lin.shape[:2]
    for d in np.flatnonzero(drops.sprite >= 0):
        s = drops.sprite[d]
        i = np.arange(start[s], start[s] + length[s])
        x, y = drops.u[d] + du[i], drops.v[d] + dv[i]
        ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
        i, x, y = i[ok], x[ok], y[ok]
        cx, cy = (drops.u[d] + 0.5) / factor - 0.5, (drops.v[d] + 0.5) / factor - 0.5
        mean = _bilinear(wide, np.array([cx]), np.array([cy]))
        if uniform[s]:
            seen = np.repeat(mean, len(i), axis=0)
        else:
            seen = _bilinear(small, cx + src_du[i] / factor, cy + src_dv[i] / factor)
        a, ws = alpha[i][:, None], w_scene[i][:, None]
        lin[y, x] = lin[y, x] * (1.0 - a) + ws * seen + (a - ws) * rim * mean
