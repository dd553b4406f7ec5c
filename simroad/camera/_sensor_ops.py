"""Pure per-frame operations of the camera sensor: vignetting, motion blur, noise, ADC + response, JPEG.

Each is a function of arrays and physical parameters (plus read-only caches keyed by
the image geometry); :mod:`simroad.camera.sensor` composes them in physical order
(see its docstring and docs/camera.md). The frame itself goes through the fused
compiled pass of :mod:`simroad.camera._sensor_kernel` from the exposure on (the
OpenCV noise and response steps here are its reference); the motion blur is the
compiled :mod:`simroad.camera._blur_kernel`.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from simroad.camera._blur_kernel import NEAR_RADII, face_edges, radial_blur
from simroad.core.radiometry import linear_to_srgb
from simroad.errors import InvalidParameterError

__all__ = [
    "NoiseTile",
    "adc_response_lut",
    "add_noise_dn",
    "gain_row_buffers",
    "inv_cos_bearing",
    "jpeg_roundtrip",
    "motion_blur_scale",
    "near_edge_maps",
    "ones_map",
    "radial_motion_blur",
    "response_curve",
    "vignetting_gain",
    "vignetting_map",
]


def vignetting_gain(
    height: int, width: int, focal_px: float, cx: float, cy: float, exponent: float = 4.0
) -> np.ndarray:
    """cos^n of each pixel's field angle: ``(f^2 / (f^2 + r^2))^(n / 2)``, per channel.

    ``n = 4`` is the natural vignetting of a thin lens (the cos^4 law); real lenses
    partly compensate it, which a smaller ``n`` models.

    Parameters
    ----------
    height, width : int
        Image size in pixels.
    focal_px : float
        Focal length in pixels.
    cx, cy : float
        Principal point in pixels (column, row).
    exponent : float
        ``n``, the power of the cosine.

    Returns
    -------
    ndarray, float32, (H, W, 3)
        Relative illumination in (0, 1], 1 on the optical axis (read-only, cached).
    """
    return _vignetting_gain(int(height), int(width), float(focal_px), float(cx), float(cy), float(exponent))


@functools.lru_cache(maxsize=8)
def _vignetting_gain(height: int, width: int, focal_px: float, cx: float, cy: float, exponent: float) -> np.ndarray:
    gain = np.repeat(vignetting_map(height, width, focal_px, cx, cy, exponent)[:, :, None], 3, axis=2)
    gain.flags.writeable = False
    return gain


@functools.lru_cache(maxsize=8)
def vignetting_map(height: int, width: int, focal_px: float, cx: float, cy: float, exponent: float) -> np.ndarray:
    """The single-channel cos^n map of :func:`vignetting_gain`, float32 (H, W), read-only, cached."""
    # One map per camera: computed once, shared read-only by every frame.
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    r2 = (u - cx) ** 2 + (v - cy) ** 2
    f2 = focal_px * focal_px
    gain = ((f2 / (f2 + r2)) ** (exponent / 2.0)).astype(np.float32)
    gain.flags.writeable = False
    return gain


@functools.lru_cache(maxsize=4)
def ones_map(h: int, w: int) -> np.ndarray:
    """The relative illumination without vignetting, float32 (H, W), read-only."""
    ones = np.ones((h, w), np.float32)
    ones.flags.writeable = False
    return ones


def gain_row_buffers(w: int) -> tuple[np.ndarray, np.ndarray]:
    """A row buffer of 3W float32 and a read-only view of it (see
    :func:`simroad.camera._sensor_kernel.expose_frame`)."""
    rw = np.empty(3 * w, np.float32)
    ro = rw.view()
    ro.flags.writeable = False
    return rw, ro


# ------------------------------------------------------------------ motion blur


@functools.lru_cache(maxsize=8)
def _flow_grids(height: int, width: int, cx: float, foe_row: float) -> tuple[np.ndarray, ...]:
    """u, v, u - cx, v - foe_row and |p - FOE|, each float32 (H, W), read-only."""
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    du, dv = u - np.float32(cx), v - np.float32(foe_row)
    grids = (u, v, du, dv, np.hypot(du, dv))
    for g in grids:
        g.flags.writeable = False
    return grids


@functools.lru_cache(maxsize=8)
def inv_cos_bearing(width: int, focal_px: float, cx: float) -> np.ndarray:
    """1 / cos of each column's bearing, ``hypot(f, u - cx) / f``, float32 (W,), read-only, cached."""
    du = np.arange(width, dtype=np.float64) - cx
    row = (np.hypot(focal_px, du) / focal_px).astype(np.float32)
    row.flags.writeable = False
    return row


def motion_blur_scale(depth: np.ndarray, *, focal_px: float, cx: float, travel_m: float) -> np.ndarray:
    """Relative image expansion of each pixel's scene point during the exposure.

    The scene points that cross pixel ``p`` during the exposure (which ends at the
    rendered pose) lie, at its end, on the segment ``p + t (p - e) s``, ``t`` in
    [0, 1], ``e`` the focus of expansion (principal column, horizon row): the point a
    pixel sees at forward distance ``X`` (m) was ``travel_m`` farther at the start,
    and a pinhole image scales as ``1 / X``, so ``s = travel / (X - travel)``. ``X`` is
    the depth map's horizontal distance times the cosine of the column's bearing.

    Parameters
    ----------
    depth : ndarray, float32, (H, W)
        Horizontal distance in metres of what each pixel sees, ``inf`` for the sky.
    focal_px : float
        Focal length in pixels.
    cx : float
        Principal column in pixels.
    travel_m : float
        Distance the ego covers during the exposure (speed times exposure time), >= 0.

    Returns
    -------
    ndarray, float32, (H, W)
        ``s`` in [0, 1]; 0 where nothing moves (sky, zero travel). The blur length in
        pixels is ``s * |p - e|``.
    """
    h, w = depth.shape
    if travel_m <= 0.0:
        return np.zeros((h, w), np.float32)
    inv_cos = np.broadcast_to(inv_cos_bearing(w, float(focal_px), float(cx)), (h, w))
    # s = travel / (X - travel), X = depth * cos(bearing); inf depth -> 0.
    x = np.divide(np.asarray(depth, np.float32), inv_cos)
    np.subtract(x, np.float32(travel_m), out=x)
    np.maximum(x, np.float32(travel_m), out=x)  # a point closer than one travel: s capped at 1
    return np.divide(np.float32(travel_m), x, out=x)


def near_edge_maps(face_id: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a face's motion blur may reach another face: for each radius ``r`` of
    :data:`~simroad.camera._blur_kernel.NEAR_RADII`, uint8 (H, W), 0 where every pixel
    within ``r`` (chessboard distance) shows the pixel's own face id.

    Parameters
    ----------
    face_id : ndarray, int32, (H, W)
        The renderer's face map (-1 for the ground and the sky), C-contiguous.
    """
    edges = np.empty(face_id.shape, np.uint8)
    face_edges(face_id, edges)
    ra, rb = NEAR_RADII
    a = cv2.dilate(edges, _square(ra))
    return a, cv2.dilate(a, _square(rb - ra))  # squares add up: radius ra, then rb - ra more


@functools.lru_cache(maxsize=4)
def _square(radius: int) -> np.ndarray:
    return np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)


def radial_motion_blur(
    lin: np.ndarray, scale: np.ndarray, *, cx: float, foe_row: float, max_step_px: float = 1.0
) -> np.ndarray:
    """Box-blur each pixel along its flow line from the focus of expansion, in place.

    Pixel ``p`` integrates the radiance found at ``p + t (p - e) s(p)`` for ``t`` in
    [0, 1] (the points that crossed it during the exposure, which ends at the rendered
    pose). The box of length ``L = s |p - e|`` is sampled with ``2**n`` bilinear taps
    no more than ``max_step_px`` apart, ``n = ceil(log2(L / max_step_px + 1))``, built
    by ``n`` doublings (each averages the pixel with the previous doubling's value a
    power-of-two number of tap spacings along its flow). Each pixel takes only the
    doublings its own blur needs (none below half a pixel), so the cost follows the
    blur in the frame (compiled: :func:`simroad.camera._blur_kernel.radial_blur`).

    Parameters
    ----------
    lin : ndarray, float32, (H, W, 3)
        Linear radiance, C-contiguous; modified in place and returned.
    scale : ndarray, float32, (H, W)
        Relative expansion from :func:`motion_blur_scale`.
    cx, foe_row : float
        Focus of expansion in pixels.
    max_step_px : float
        Largest spacing of the taps in pixels.

    Returns
    -------
    ndarray, float32, (H, W, 3)
        ``lin``, blurred.
    """
    if lin.dtype != np.float32 or lin.ndim != 3 or lin.shape[2] != 3 or not lin.flags.c_contiguous:
        raise InvalidParameterError(
            f"lin: expected a C-contiguous float32 (H, W, 3) array, got {lin.dtype} {lin.shape}."
        )
    if scale.shape != lin.shape[:2]:
        raise InvalidParameterError(f"scale: expected shape {lin.shape[:2]} (the frame's), got {scale.shape}.")
    radial_blur(lin, np.ascontiguousarray(scale, np.float32), float(cx), float(foe_row), float(max_step_px))
    return lin


# ------------------------------------------------------------------ noise


class NoiseTile:
    """A pre-drawn field of standard normals, read through a random window per frame.

    Drawing ``H x W x 3`` normals costs more than the rest of the sensor, so one field
    of ``(H + ph) x (W + pw) x 3`` (``ph = max(H // 2, 64)``, ``pw = max(W // 2, 64)``)
    is drawn once per episode; each frame reads the ``H x W`` window at an offset drawn
    uniformly from the generator (never the previous frame's) with a random sign. A
    window is a piece of one i.i.d. field, so nothing repeats inside a frame, and two
    frames' noise at a pixel is uncorrelated unless the offsets and signs coincide.

    Parameters
    ----------
    height, width : int
        Frame size in pixels.
    rng : numpy.random.Generator
        The episode's sensor generator (draws the field now and the offsets later).
    """

    def __init__(self, height: int, width: int, rng: np.random.Generator) -> None:
        self.height, self.width = int(height), int(width)
        self.pad = (max(self.height // 2, 64), max(self.width // 2, 64))
        shape = (self.height + self.pad[0], self.width + self.pad[1], 3)
        self.field = rng.standard_normal(shape, dtype=np.float32)
        self._last: tuple[int, int] | None = None
        self._high = np.array([self.pad[0] + 1, self.pad[1] + 1, 2])  # offsets' bounds (exclusive)

    def offsets(self, rng: np.random.Generator) -> tuple[int, int, float]:
        """The next frame's window: row and column offset into ``field`` and its sign (+1 or -1)."""
        while True:
            oy, ox, flip = (int(k) for k in rng.integers(0, self._high))
            if (oy, ox) != self._last:
                break
        self._last = (oy, ox)
        return oy, ox, (-1.0 if flip else 1.0)

    def window(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """The next frame's noise: an (H, W, 3) float32 view and its sign (+1 or -1)."""
        oy, ox, sign = self.offsets(rng)
        return self.field[oy : oy + self.height, ox : ox + self.width], sign


def add_noise_dn(
    signal_dn: np.ndarray,
    normal: np.ndarray | None,
    *,
    sign: float = 1.0,
    gain_dn_per_e: float,
    shot: bool,
    read_noise_e: float,
) -> np.ndarray:
    """Add shot and read noise (EMVA 1288) to a signal in digital numbers and digitise it.

    The signal ``mu_e = signal_dn / K`` electrons (``K`` the conversion gain) has the
    variance ``mu_e + sigma_read^2`` (Poisson shot noise in its normal approximation
    plus read noise), i.e. ``K * signal_dn + (K sigma_read)^2`` in DN^2.

    Parameters
    ----------
    signal_dn : ndarray, float32, (H, W, 3)
        Expected signal in DN (not modified).
    normal : ndarray, float32, (H, W, 3) or None
        Standard normal samples (a :class:`NoiseTile` window); None when no noise is on.
    sign : float
        +1 or -1, multiplies ``normal``.
    gain_dn_per_e : float
        Conversion gain K in DN per electron.
    shot : bool
        Photon shot noise on.
    read_noise_e : float
        Read noise standard deviation in electrons.

    Returns
    -------
    ndarray, uint16, (H, W, 3)
        Rounded, saturated digital numbers.
    """
    if normal is None or (not shot and read_noise_e == 0.0):
        return cv2.add(signal_dn, 0.0, dtype=cv2.CV_16U)  # type: ignore[call-overload,unused-ignore]
    k = float(gain_dn_per_e)
    floor = (k * float(read_noise_e)) ** 2
    var = cv2.addWeighted(signal_dn, k if shot else 0.0, signal_dn, 0.0, floor)
    np.maximum(var, np.float32(0.0), out=var)
    sigma = cv2.sqrt(var)
    cv2.multiply(sigma, normal, dst=sigma, scale=float(sign))
    return cv2.add(signal_dn, sigma, dtype=cv2.CV_16U)


# ------------------------------------------------------------------ response, JPEG


def response_curve(y: np.ndarray, *, shoulder: float, gamma: float) -> np.ndarray:
    """The camera response: ``((1 + k) y / (1 + k y)) ** gamma`` on ``y`` in [0, 1].

    Maps 0 to 0 and 1 to 1; the shoulder ``k`` lifts shadows and compresses
    highlights as a filmic curve does.
    """
    y = np.clip(np.asarray(y, dtype=np.float64), 0.0, 1.0)
    if shoulder > 0.0:
        y = (1.0 + shoulder) * y / (1.0 + shoulder * y)
    if gamma != 1.0:
        y = y**gamma
    return y.astype(np.float32)


@functools.lru_cache(maxsize=8)
def adc_response_lut(adc_bits: int, shoulder: float, gamma: float) -> np.ndarray:
    """Digital number (0..65535) to the encoded 8-bit output: response curve, then sRGB.

    Entry ``d`` is ``encode(response(d / (2**adc_bits - 1)))``; every ``d`` at or above
    full scale is 255 (saturation).

    Returns
    -------
    ndarray, uint8, (65536,)
        Read-only table for ``np.take``.
    """
    full = 2**adc_bits - 1
    y = response_curve(np.minimum(np.arange(65536, dtype=np.float64) / full, 1.0), shoulder=shoulder, gamma=gamma)
    table = linear_to_srgb(y.reshape(256, 256, 1).repeat(3, axis=2))[..., 0].ravel().copy()
    table.flags.writeable = False
    return table


def jpeg_roundtrip(rgb: np.ndarray, quality: int) -> np.ndarray:
    """Encode and decode an RGB uint8 frame as JPEG at ``quality`` (1..100)."""
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
    if decoded is None:
        raise InvalidParameterError("jpeg_quality: OpenCV could not encode and decode the frame as JPEG.")
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)
