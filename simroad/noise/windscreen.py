"""Drops on the windscreen and the wiper: adherent raindrops (and melted flakes) as blurred lenses.

The glass is in front of the lens, so the windscreen acts on the scene's radiance
after the falling drops (stage ``particles``) and before the lens's veiling glare and
the sensor (stage ``optics``; the camera's sensor runs after all weather): it is the
``windscreen`` stage of :data:`simroad.noise.model.STAGES`.

Physics
-------
* **The glass** — a plane ``glass_distance_m`` (0.1 m) in front of the lens along the
  optical axis, tilted back ``glass_tilt_deg`` (55°) from vertical, as a car's
  windscreen before a camera at the mirror. Rows below the axis see it farther away and
  more obliquely (0.06–0.4 m at the default mounting), so drops there look smaller and
  flatter, and more of them are in view: the fraction of the image they cover is that of
  the glass.
* **Collection** — drops in the air hit the glass at the rate
  ``Σ n_i·(v·cos φ + w_i·sin φ)`` per m² of glass (n_i drops per m³ falling at w_i, the
  car at v, the glass tilted back by φ from vertical): a headwind collects drops
  (:func:`collection_rate`; 15 800 /m²/s at 25 mm/h and 15 m/s). Rain drops follow
  Marshall–Palmer at the rain's rate (0.5–7 mm, Gunn–Kinzer speeds); snowflakes (the
  snow's 1–5 mm flakes at 0.5–2 m/s) melt on the glass into drops of the same mass
  (flake density ``snow_density_kg_m3``). Each arrival leaves a sessile spherical cap of
  the same volume and contact angle ``contact_angle_deg`` (50°, weathered glass;
  :func:`~simroad.noise._glass.contact_radius`: a 1 mm raindrop spreads to a 0.87 mm
  contact radius), capped at ``max_contact_radius_mm``, at a uniformly random point of
  the glass in view. Arrivals stop when the drops cover ``max_coverage`` of the glass
  (real drops would merge) or number ``max_drops``.
* **Appearance** — each drop is a water lens (Roser & Geiger 2009; Halimeh & Roser
  2009): a ray leaving the cap at normalised radius ρ is bent by
  ``asin(n·ρ·sin γ) − asin(ρ·sin γ)`` towards and past the axis, so the drop shows a
  small, inverted, wide-angle view (up to 40° off its line of sight at 50°) of the scene —
  the sky in its lower part, the road in its upper part — dimmed by the Fresnel loss at
  its surface, and beyond ``ρ = 1/(n·sin γ)`` the rays are totally reflected: that rim
  shows ``rim_brightness`` of the drop's mean view (:mod:`simroad.noise._glass`). The
  camera is focused far away (``focus_m``), so the glass is blurred by the thin-lens
  defocus disc ``c = A·f·|S − z|/(z·(S − f))`` (A = f/N, 2 mm for the default 4 mm f/2
  lens: 4.5 px at 10 cm for the 320-px camera). The ratio of that blur to the drop's own
  image, ``A/(2a)``, depends neither on the glass distance nor on the resolution: a
  1.7 mm wide drop is blurred over more than its width. A blurred drop covers part of
  the aperture, so the camera sees ``(1 − α)·scene + α·drop`` with α the drop's coverage
  blurred by the disc — the scene behind stays sharp.
* **Running drops** — along the glass, the airflow pushes a drop up with a force that
  grows as ``v²·a²``, gravity pulls it down with ``a³``, and contact-angle hysteresis
  holds it with a force ``∝ a`` (Furmidge 1962). In units of gravity's pull: net
  ``(v/v_c)²·(a_s/a) − 1``, holding ``(a_s/a)²``, where ``a_s = slide_radius_mm`` (2 mm)
  is the drop that just runs down a still car's glass and ``v_c = airflow_speed_m_s``
  (25 m/s) the car speed at which the airflow's push on it equals gravity's pull (an
  estimate: drops of tens of µL shed in air streams of 10–20 m/s on hydrophilic
  surfaces, Milne & Amirfazli 2009, and the glass's boundary layer slows the air at a
  drop to about half the car's speed). A drop whose net force exceeds the holding one
  runs at ``slide_speed_m_s`` times the excess (capped at 2): drops over 2 mm run down a
  slow car's glass, and above 35 m/s (√2·v_c) drops creep up it. A running drop keeps
  the sprite of where it formed.
* **Wiper** — a blade turning about a pivot below the view (:mod:`simroad.noise._wiper`)
  sweeps an arc up and back in two strokes of ``wiper_stroke_s``; every drop whose
  centre the blade passes is gone. ``wiper_period_s``: seconds between cycle starts
  (at least two strokes), a mode (``"fast"`` 1 s = 60 cycles/min, ``"slow"`` 1.5 s = 40
  cycles/min — FMVSS 104 asks for at least 45 cycles/min at the high speed and a lower
  speed at least 15 cycles/min slower —, ``"intermittent"`` 5 s), ``"off"``/None, or
  ``"auto"`` (default): a rain sensor that starts a cycle when drops cover
  ``sensor_coverage`` of the glass. The blade itself is seen, defocused, as a dark band
  while it crosses the view (a frame or two per stroke at 15 frames/s).

The first frame of an episode shows the glass as the rain left it since the last
wipe (a random phase of the wiper cycle; 60 s of rain with the wiper off).

Rendering and mask
------------------
A drop's image is a sprite (:class:`~simroad.noise._glass.Sprite`): its defocused
coverage and, per pixel, where its refracted light comes from, made once per image
size and blur (quantised in steps of 10 %) and kept in a bank shared by every episode;
a frame costs one compiled pass over the drops' pixels
(:mod:`simroad.noise._drops_kernel`) that samples the scene reduced 4x (``scene_low_pass``);
drops less than 5 px wide are drawn in one colour, their mean view. The mask
``"windscreen"`` is where a drop (or the blade) covers at least a tenth of the lens's
aperture, together with every other pixel they changed by 8 grey levels: a drop is in
the mask even over a background of its own colour, so the mask of a drop that stays put
stays put.

References: Roser & Geiger, *Video-based raindrop detection for improved image
registration*, ICCV workshops 2009; Halimeh & Roser, *Raindrop detection on car
windshields using geometric-photometric environment construction and
intensity-based correlation*, IEEE IV 2009; Marshall & Palmer 1948; Furmidge, J.
Colloid Sci. 1962; Milne & Amirfazli, Langmuir 2009 (drop shedding by shear flow);
FMVSS 104 (windshield wiping and washing systems).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simroad.core.validation import check_in_range
from simroad.errors import InvalidParameterError
from simroad.noise._drops import DropField, SpriteBank, draw_drops
from simroad.noise._drops_kernel import COVERED, advance_drops
from simroad.noise._glass import Glass, GlassView, contact_radius, glass_view
from simroad.noise._windscreen_params import (
    WindscreenParams,
    _sources,
    slide_velocity,
)
from simroad.noise._wiper import blade_angle, blade_coverage, swept_interval
from simroad.noise.context import FrameState
from simroad.noise.model import NoiseModel
from simroad.noise.rain import RainParams

__all__ = [
    "WindscreenModel",
]

#: Sprite banks by camera, glass and contact angle, shared by every episode.
_BANKS: dict[tuple[Any, Glass, float], SpriteBank] = {}
_OFF_FILL_S = 60.0  # wiper off: the first frame shows this much rain on the glass


class WindscreenModel(NoiseModel):
    """Drops on the windscreen and the wiper (see the module docstring).

    :func:`simroad.noise.make_weather` adds it to rain and snow (``windscreen=True``,
    the default), with the rain's rate and the snow's flake density.

    Parameters
    ----------
    params : WindscreenParams
    rain_rate_mm_h : float
        Rain rate, mm/h, in [0, 300] (keyword-only).
    flake_density_m3 : float
        Snowflakes per m³, in [0, 20000].

    Attributes
    ----------
    drops : DropField
        The drops on the glass (glass positions, contact radii, image positions,
        sprites).
    blade_visible : bool
        Whether the wiper blade crossed the view in the last frame.
    """

    name = "windscreen"
    params_type = WindscreenParams
    stages = ("windscreen",)

    def __init__(self, params: WindscreenParams, *, rain_rate_mm_h: float = 0.0, flake_density_m3: float = 0.0) -> None:
        super().__init__(params)
        self.rain_rate_mm_h = check_in_range("rain_rate_mm_h", rain_rate_mm_h, 0.0, 300.0, unit="mm/h")
        self.flake_density_m3 = check_in_range("flake_density_m3", flake_density_m3, 0.0, 20000.0, unit="1/m^3")
        n, d, w = _sources(self.rain_rate_mm_h, self.flake_density_m3, params.snow_density_kg_m3)
        a = np.minimum(contact_radius(d, params.contact_angle_deg), params.max_contact_radius_mm * 1e-3)
        self._bins = (n, a, w)
        self._on_reset()

    @classmethod
    def from_severity(cls, severity: float) -> WindscreenModel:
        """Default glass and wiper, in the rain of ``severity`` (``RainParams.from_severity``)."""
        s = check_in_range("severity", severity, 0.0, 1.0)
        return cls(WindscreenParams.from_severity(s), rain_rate_mm_h=RainParams.from_severity(s).rate_mm_h)

    @property
    def is_identity(self) -> bool:
        """Nothing falls on the glass: the frames are left unchanged."""
        return self.rain_rate_mm_h == 0.0 and self.flake_density_m3 == 0.0

    @property
    def coverage(self) -> float:
        """Fraction of the glass in view the drops cover (0 before the first frame)."""
        return 0.0 if self._view is None else self.drops.coverage(self._view.view_area_m2)

    def _on_reset(self) -> None:
        self.drops = DropField()
        self.blade_visible = False
        self._clock: float | None = None  # s since the first frame
        self._cycle_start = -math.inf  # start of the latest wipe cycle, s
        self._view: GlassView | None = None
        self._pivot_maps: tuple[np.ndarray, np.ndarray, float, float] | None = None
        self._projection: np.ndarray | None = None
        self._rate_cache: tuple[tuple[float, float], float, np.ndarray] | None = None

    # ----------------------------------------------------------- the stage
    def windscreen(self, state: FrameState) -> None:
        p, ctx = self.params, state.ctx
        rng = self._require_reset()
        view = self._glass_view(state)
        speed = abs(ctx.ego_speed)
        if self._clock is None or view is not self._view:
            self._start(view, speed, rng)
            now = 0.0
        else:
            before = self._clock
            now = self._clock = before + ctx.dt
            self._arrive(view, speed, ctx.dt, rng)
            self._advance(view, speed, ctx.dt, before, now)
            if p.wiper_period_s == "auto" and now - self._cycle_start >= 2.0 * p.wiper_stroke_s:
                if self.drops.coverage(view.view_area_m2) >= p.sensor_coverage:
                    self._cycle_start = now  # the rain sensor starts a cycle
        factor = max(1, round(state.shape[1] / 80))
        touched = np.zeros(state.shape, bool)  # the runner encodes these pixels only
        bank = self._bank(view)
        state.covered = draw_drops(state.lin, self.drops, bank, rim=p.rim_brightness, factor=factor, touched=touched)
        self._draw_blade(state.lin, view, now, state.covered, touched)
        state.touched = touched

    def _bank(self, view: GlassView) -> SpriteBank:
        key = (view.config, view.glass, self.params.contact_angle_deg)
        bank = _BANKS.get(key)
        if bank is None:
            bank = _BANKS.setdefault(key, SpriteBank(view, self.params.contact_angle_deg))
        return bank

    def _may_slide(self, speed: float) -> bool:
        """Whether any drop may run: below √2 times ``airflow_speed_m_s`` only drops
        bigger than ``slide_radius_mm`` can (see :func:`slide_velocity`)."""
        p = self.params
        if len(self.drops) == 0:
            return False
        return (
            speed >= math.sqrt(2.0) * p.airflow_speed_m_s or float(self.drops.radius.max()) > p.slide_radius_mm * 1e-3
        )

    def _glass_view(self, state: FrameState) -> GlassView:
        p = self.params
        pitch = state.camera.config.pitch_deg
        if p.glass_tilt_deg + pitch >= 89.0:
            raise InvalidParameterError(
                f"glass_tilt_deg: {p.glass_tilt_deg:g} degrees with the camera's pitch of {pitch:g} degrees puts the "
                "glass along the optical axis; expected a tilt below 89 degrees minus the pitch."
            )
        return glass_view(state.camera, p.glass)

    # ------------------------------------------------------------ arrivals
    def _rate(self, view: GlassView, speed: float) -> tuple[float, np.ndarray]:
        """Arrivals per second on the glass in view, and the cumulative share of the
        size bins (cached for the last speed)."""
        key = (speed, view.view_area_m2)
        if self._rate_cache is None or self._rate_cache[0] != key:
            n, _, w = self._bins
            tilt = math.radians(self.params.glass_tilt_deg)
            per_bin = n * (speed * math.cos(tilt) + w * math.sin(tilt))
            total = float(per_bin.sum())
            cum = np.cumsum(per_bin / total) if total > 0 else np.zeros_like(per_bin)
            self._rate_cache = (key, total * view.view_area_m2, cum)
        return self._rate_cache[1], self._rate_cache[2]

    def _arrive(self, view: GlassView, speed: float, duration_s: float, rng: np.random.Generator) -> None:
        """The drops that hit the glass in view during ``duration_s`` form at uniform
        points of it (the centres of the pixels that see them), while there is room."""
        rate, cum_share = self._rate(view, speed)
        count = int(rng.poisson(rate * duration_s)) if rate > 0.0 else 0
        if count <= 0:
            return
        p = self.params
        draw = rng.random((2, count))
        radius = self._bins[1][np.minimum(cum_share.searchsorted(draw[0] * cum_share[-1]), len(cum_share) - 1)]
        pixel = view.area_cdf.searchsorted(draw[1] * view.area_cdf[-1], side="right")  # uniform on the glass
        pixel = np.minimum(pixel, view.area_cdf.size - 1)
        area = np.pi * radius**2 / view.view_area_m2
        room = p.max_coverage - self.drops.coverage(view.view_area_m2)
        if area.sum() > room or len(self.drops) + count > p.max_drops:  # the glass is full
            fits = np.cumsum(area) <= room
            fits[max(0, p.max_drops - len(self.drops)) :] = False
            pixel, radius = pixel[fits], radius[fits]
        self.drops.add(view, self._bank(view), pixel, radius, min_px=p.min_drop_px)

    def _start(self, view: GlassView, speed: float, rng: np.random.Generator) -> None:
        """The first frame: the glass as the rain left it since the last wipe."""
        p = self.params
        self.drops, self._view, self._clock = DropField(), view, 0.0
        self._pivot_maps = None
        self._projection = None
        rate, cum_share = self._rate(view, speed)
        if p.wiper_period_s is None:
            since = _OFF_FILL_S
        elif p.wiper_period_s == "auto":  # somewhere between two triggers of the sensor
            share = np.diff(cum_share, prepend=0.0)
            per_s = rate * float(np.sum(share * np.pi * self._bins[1] ** 2)) / view.view_area_m2
            since = float(rng.random()) * (p.sensor_coverage / per_s if per_s > 0 else 0.0)
            self._cycle_start = -math.inf
        else:
            since = float(rng.random()) * float(p.wiper_period_s)
            self._cycle_start = -since
        self._arrive(view, speed, since, rng)
        self._wipe(view, -since, 0.0)

    # --------------------------------------------------------------- wiper
    def _cycles(self, t0: float, t1: float) -> list[float]:
        """Start times of the wipe cycles that run during ``(t0, t1]``."""
        period, stroke = self.params.wiper_period_s, self.params.wiper_stroke_s
        if period is None:
            return []
        if period == "auto":
            return [self._cycle_start] if self._cycle_start > t0 - 2.0 * stroke else []
        first = self._cycle_start + math.floor((t0 - 2.0 * stroke - self._cycle_start) / period) * period
        return [s for s in np.arange(first, t1, period) if s + 2.0 * stroke > t0]

    def _swept(self, t0: float, t1: float) -> np.ndarray:
        """The blade angles ``[lo, hi]`` swept during ``(t0, t1]``, (k, 2) radians."""
        p = self.params
        arc = math.radians(p.wiper_arc_deg)
        spans = [swept_interval(t0 - s, t1 - s, p.wiper_stroke_s, arc) for s in self._cycles(t0, t1)]
        return np.array([s for s in spans if s is not None], np.float64).reshape(-1, 2)

    def _wipe(self, view: GlassView, t0: float, t1: float) -> None:
        """Remove the drops the blade passed over during ``(t0, t1]`` (nothing moves)."""
        self._advance(view, 0.0, 0.0, t0, t1, slide=False)

    def _advance(self, view: GlassView, speed: float, dt: float, t0: float, t1: float, *, slide: bool = True) -> None:
        """One frame of the drops running along the glass (those that may, see
        :func:`slide_velocity`; none unless ``slide``) and of the wiper over ``(t0, t1]``,
        in one compiled pass (:func:`~simroad.noise._drops_kernel.advance_drops`;
        :meth:`DropField.move` is its numpy reference for the motion)."""
        p = self.params
        if len(self.drops) == 0:
            return
        velocity = slide_velocity(self.drops.radius, speed, p) if slide and self._may_slide(speed) else None
        swept = self._swept(t0, t1)
        if velocity is None and len(swept) == 0:
            return
        if velocity is None:
            velocity = np.zeros(len(self.drops))
        if self._projection is None:
            self._projection = view.projection()
        d, size = self.drops, (view.config.width, view.config.height)
        wiper = (float(p.wiper_pivot_m[0]), float(p.wiper_pivot_m[1]), float(p.wiper_length_m))
        alive = advance_drops(d.gx, d.gy, velocity, d.u, d.v, float(dt), self._projection, size, wiper, swept)
        d.keep(alive)

    def _draw_blade(
        self, lin: np.ndarray, view: GlassView, now: float, covered: np.ndarray, touched: np.ndarray
    ) -> None:
        """The blade, defocused, where it crosses the view at ``now`` (marked in ``covered``
        where it hides at least :data:`COVERED` of a pixel, in ``touched`` where it hides any)."""
        p = self.params
        self.blade_visible = False
        starts = [s for s in self._cycles(now - 1e-9, now) if s <= now]
        if not starts:
            return
        alpha = blade_angle(now - starts[-1], p.wiper_stroke_s, math.radians(p.wiper_arc_deg))
        edge = p.glass.aperture_m  # the defocus disc, measured on the glass
        if self._pivot_maps is None:
            rel_x, rel_y = view.gx - np.float32(p.wiper_pivot_m[0]), view.gy - np.float32(p.wiper_pivot_m[1])
            ang = np.arctan2(rel_y, rel_x)
            lo, hi = float(ang.min()), float(ang.max())
            if hi - lo > math.pi:  # the view surrounds the pivot's left: no simple range
                lo, hi = -math.inf, math.inf
            margin = (0.5 * p.wiper_width_m + edge) / max(float(np.hypot(rel_x, rel_y).min()), 1e-3)
            self._pivot_maps = (rel_x, rel_y, lo - margin, hi + margin)
        rel_x, rel_y, lo, hi = self._pivot_maps
        if not lo <= alpha <= hi:  # the blade is out of view
            return
        cov = blade_coverage(rel_x, rel_y, alpha, width_m=p.wiper_width_m, length_m=p.wiper_length_m, edge_m=edge)
        rows = np.flatnonzero(cov.any(axis=1))
        if len(rows) == 0:
            return
        r = slice(int(rows[0]), int(rows[-1]) + 1)
        c = cov[r][..., None]
        lin[r] = lin[r] * (1.0 - c) + c * np.float32(p.blade_radiance)
        covered[r] |= cov[r] >= COVERED
        touched[r] |= cov[r] > 0.0
        self.blade_visible = True
