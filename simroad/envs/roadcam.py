"""``simroad/RoadCam-v0``: a dashboard camera on highway-env, with exact ground truth."""

from __future__ import annotations

import math
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

from simroad.camera import CameraRenderer, Frame, PinholeCamera, Sensor, VehicleBox, WorldRaster, render_bev
from simroad.camera.palette import draw_palette
from simroad.camera.sky import SKY_VIEW
from simroad.camera.vehicles import draw_paint, paint_rgb
from simroad.core.opencv import opencv_without_ipp
from simroad.core.validation import check_choice, check_in_range, check_int_in_range
from simroad.envs import _world_cache
from simroad.envs.config import RoadCamConfig
from simroad.envs.friction import RoadGrip, road_grip
from simroad.envs.scenarios import POLICY_HZ, get_scenario
from simroad.envs.tyres import attach_grip
from simroad.errors import InvalidParameterError, ResetNeededError
from simroad.noise import NoiseContext, Weather, make_weather

__all__ = ["RoadCamEnv"]


def _action_array(action: Any, shape: tuple[int, ...] | None) -> np.ndarray:
    """The action as a flat float64 array, refusing what is not numbers (strings, dicts, None)."""
    n = shape[0] if shape else 1
    hint = f"expected {n} number(s) in [-1, 1] (an array of shape {shape})"
    if isinstance(action, (str, bytes)) or action is None:
        raise InvalidParameterError(f"action: {hint}, got {type(action).__name__} {action!r}.")
    try:
        a = np.asarray(action, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"action: {hint}, got {type(action).__name__} {action!r}.") from None
    return a


class RoadCamEnv(gym.Env):
    """A dashboard camera on a highway-env car, in clear or bad weather.

    The world (road surface, markings, shoulders, roadside) is rasterised from
    highway-env's road network once per episode and seen through a pinhole camera
    on the ego; the weather spoils the picture; ``info`` carries the exact truth.

    ## Action Space
    ``Box(-1, 1, (1,), float32)``: steering, 1.0 = pi/4 rad to the right. With
    ``longitudinal=True``, ``Box(-1, 1, (2,))``: ``[steering, acceleration]``,
    acceleration 1.0 = 5 m/s^2. NaN or infinite actions raise an error.

    ## Observation Space
    ``Box(0, 255, (height, width, 3), uint8)``: the (noisy) RGB camera frame.

    ## Rewards
    ``on_road * 1 / (1 + lateral_offset_m**2) - crashed``; the terms are in
    ``info["rewards"]``. Drivers in simroad are scored on the mask and safety
    metrics, not on this reward; it is there for RL users.

    ## Episode End
    Terminated when the ego crashes or its centre is more than ``max_offroad_m``
    off the road surface; truncated after ``duration_s`` simulated seconds, or at
    the end of the ``winding`` road.

    ## Info
    ``road_mask`` (bool HxW, visible drivable surface), ``depth`` (float32 HxW,
    ground distance in m, inf for sky), ``material`` (uint8 HxW material codes),
    ``noise_masks`` (dict noise -> bool HxW; with rain or snow also ``"windscreen"``,
    the drops on the glass and the wiper blade), ``pose`` (float64 [x, y, heading]),
    ``speed_m_s``, ``lateral_offset_m`` (to the centre of the closest lane, + is
    right), ``heading_error_rad``, ``lane_width_m``, ``on_road``, ``crashed``,
    ``time_s``, ``rewards``; ``mu`` (the tyre–road friction coefficient under the
    ego, None with ``friction=False``) and ``sliding`` (the tyres slid during the
    step: the car turned or braked less than it asked).

    ## Friction
    With ``friction=True`` (default) every moving car obeys the friction circle
    ``|a| <= μ·g``, μ from the weather (:mod:`simroad.envs.friction`; dry asphalt
    0.8 rarely binds at the scenarios' speeds); ``env.grip`` gives μ anywhere.

    ## Arguments
    ``gymnasium.make("simroad/RoadCam-v0", scenario="winding", width=640,
    height=360, noise="rain+glare", severity=0.7)``; see :class:`RoadCamConfig`.
    Either keywords or ``config=RoadCamConfig(...)``, not both.

    ## Reset
    ``reset(seed=...)`` draws a new world (palette, textures), new traffic and a new
    weather state from the seed. ``options`` takes no keys; a non-empty dict is
    refused.

    ## Ground-truth driving
    The environment carries no policy; :func:`simroad.control.autopilot_action`
    steers along the true lane centre given ``env.highway_env.road`` and
    ``env.vehicle``.
    """

    # gymnasium.Env declares ``metadata`` as a plain (instance-typed) attribute.
    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": POLICY_HZ}  # noqa: RUF012

    def __init__(self, render_mode: str | None = None, *, config: RoadCamConfig | None = None, **kwargs: Any) -> None:
        if render_mode is not None:
            check_choice("render_mode", render_mode, self.metadata["render_modes"])
        if config is not None and kwargs:
            raise InvalidParameterError(
                f"config: got config=RoadCamConfig(...) together with the keywords {', '.join(sorted(kwargs))}, "
                "which it would silently override. Pass either config= or keywords, e.g. "
                "config=dataclasses.replace(config, ...)."
            )
        if config is not None and not isinstance(config, RoadCamConfig):
            raise InvalidParameterError(f"config: expected a RoadCamConfig, got {type(config).__name__}.")
        self.render_mode = render_mode
        self.config = config if config is not None else RoadCamConfig.from_kwargs(**kwargs)
        c = self.config
        self.scenario = get_scenario(c.scenario)
        self.camera = PinholeCamera(c.camera)
        self._hw = self.scenario.make_env(longitudinal=c.longitudinal, traffic=c.traffic, duration_s=c.duration_s)
        self.dt = self.scenario.policy_period_s
        H, W = c.camera.height, c.camera.width
        self.observation_space = spaces.Box(0, 255, (H, W, 3), dtype=np.uint8)
        n = 2 if c.longitudinal else 1
        self.action_space = spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)
        # Per-episode state, (re)built by reset().
        self.world: WorldRaster | None = None
        self.renderer: CameraRenderer | None = None
        self.weather: Weather | None = None
        self.sensor: Sensor | None = None
        self.grip: RoadGrip | None = None
        self._slides = 0
        self._vehicle_rgb: dict[int, tuple[tuple[int, int, int], tuple[float, float, float]]] = {}
        self._colour_rng: np.random.Generator | None = None
        self._prev_heading = 0.0
        self._time = 0.0
        self._obs: np.ndarray | None = None
        self._info: dict[str, Any] = {}

    # ------------------------------------------------------------------ API
    @property
    def highway_env(self):
        """The highway-env environment that drives the world."""
        return self._hw

    @property
    def vehicle(self):
        """The ego vehicle (a highway-env ``Vehicle``)."""
        return self._hw.vehicle

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        if options:
            raise InvalidParameterError(
                f"options: RoadCamEnv.reset takes no options, got {sorted(map(str, options))}. "
                "Configure the environment with its constructor keywords instead."
            )
        if seed is not None:  # a plain int for gymnasium (which refuses numpy integers and 3.0)
            seed = check_int_in_range("seed", seed, 0, 2**63 - 1)
        super().reset(seed=seed)
        opencv_without_ipp()  # OpenCV keeps the switch per thread: this one renders
        rng = self.np_random
        self._hw.reset(seed=int(rng.integers(2**31 - 1)))
        # Our roads are chains of short segments: let highway-env find the vehicle
        # ahead across segment ends (IDM traffic and the time-to-collision use it).
        self._hw.road.neighbour_vehicles_connected_lanes = True
        world_rng = np.random.default_rng(int(rng.integers(2**63 - 1)))
        cp = self.config.camera_profile
        palette = draw_palette(
            world_rng, roadside=self.config.roadside, profile=self.scenario.profile, camera_profile=cp
        )
        # Built once per process for a given road, seed and palette (:mod:`._world_cache`).
        self.world = _world_cache.world(
            self._hw.road.network,
            world_rng,
            texel_m=self.config.camera.texel_m,
            palette=palette,
            extra_markings=getattr(self._hw, "crossing_polygons", ()),  # zebras and stop lines (town)
        )
        self.renderer = CameraRenderer(
            self.camera, self.world, world_rng, profile=cp, sky_view=SKY_VIEW[self.scenario.profile]
        )
        # The world's last draw: the scenery seed (only the scenery shifts with it).
        scenery_seed = int(world_rng.integers(2**63 - 1))
        if self.config.scenery > 0:
            self.world.scenery = _world_cache.scenery(
                self.world,
                scenery_seed,
                profile=self.scenario.profile,
                density=self.config.scenery,
                shoulder_m=palette.shoulder_width_m,
                sidewalk_m=palette.kerb_width_m + palette.sidewalk_width_m,
            )
        self._vehicle_rgb = {}
        self._colour_rng = np.random.default_rng(int(rng.integers(2**63 - 1)))
        weather_rng = np.random.default_rng(int(rng.integers(2**63 - 1)))
        self.weather = None
        if self.config.noise != "clear":
            self.weather = make_weather(
                self.config.noise,
                severity=self.config.severity,
                params=self.config.noise_params,
                windscreen=self.config.windscreen,
            )
            self.weather.reset(weather_rng, world=self.world)
        self.grip = None
        if self.config.friction:  # deterministic: draws nothing
            self.grip = road_grip(self.weather, road_surface=self.config.road_surface, mu=self.config.mu)
            attach_grip(self._hw.road, self.grip)
        self._slides = 0
        self.sensor = None
        if self.config.sensor_params is not None:
            # The last draw of reset, made only when the sensor is on: with
            # camera_effects=False every other stream is unchanged.
            self.sensor = Sensor(self.config.sensor_params, self.camera)
            self.sensor.reset(
                np.random.default_rng(int(rng.integers(2**63 - 1))), illuminant_k=self.renderer.sky.illuminant_k
            )
        self._prev_heading = float(self.vehicle.heading)
        self._time = 0.0
        first = self._observe(crashed=False)
        _world_cache.remember(self.world)  # the first frame's tiles and cells, for the next reset of this world
        return first

    def step(self, action):
        a = _action_array(action, self.action_space.shape)
        if a.shape != self.action_space.shape:
            raise InvalidParameterError(f"action: expected shape {self.action_space.shape}, got {np.shape(action)}.")
        if not np.all(np.isfinite(a)):
            raise InvalidParameterError(f"action: expected finite values in [-1, 1], got {a.tolist()}.")
        if self.world is None:
            raise ResetNeededError("step() called before reset(); call env.reset(seed=...) first.")
        a = np.clip(a, -1.0, 1.0)
        self._prev_heading = float(self.vehicle.heading)
        hw_action = a[::-1] if self.config.longitudinal else a  # highway-env: [acceleration, steering]
        _, _, _, hw_truncated, _ = self._hw.step(hw_action.astype(np.float32))
        self._time += self.dt
        obs, info = self._observe(crashed=bool(self.vehicle.crashed))
        terminated = bool(info["crashed"]) or info["offroad_distance_m"] > self.config.max_offroad_m
        truncated = bool(hw_truncated) or self._time >= self.config.duration_s - 1e-9 or self._route_finished()
        return obs, float(info["rewards"]["total"]), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """The last observation with the ground-truth road outline in yellow."""
        if self.render_mode != "rgb_array" or self._obs is None:
            return None
        out = self._obs.copy()
        contours, _ = cv2.findContours(self._info["road_mask"].astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, (255, 230, 0), 1)
        return out

    def render_bev(
        self, *, size: tuple[int, int] = (240, 320), metres_per_px: float = 0.25
    ) -> tuple[np.ndarray, np.ndarray]:
        """Bird's-eye view of the world around the ego, heading up, and its road mask.

        The same as :func:`simroad.camera.render_bev` of this episode's world at the
        ego's pose, with the other vehicles: ``size`` is ``(width, height)`` in pixels,
        ``metres_per_px`` the ground resolution.

        Returns
        -------
        rgb : ndarray, uint8, (H, W, 3)
        road_mask : ndarray, bool, (H, W)
        """
        if self.world is None:
            raise ResetNeededError("render_bev() called before reset().")
        if isinstance(size, (str, bytes)) or not isinstance(size, (tuple, list)) or len(size) != 2:
            raise InvalidParameterError(f"size: expected (width, height) in pixels, got {size!r}.")
        size = (check_int_in_range("size[0]", size[0], 8, 4096), check_int_in_range("size[1]", size[1], 8, 4096))
        metres_per_px = check_in_range("metres_per_px", metres_per_px, 0.0, 100.0, low_inclusive=False)
        ego = self._box(self.vehicle, rgb=(255, 255, 255))
        return render_bev(
            self.world, self._pose(), size=size, metres_per_px=metres_per_px, vehicles=self._others(), ego=ego
        )

    def close(self) -> None:
        self._hw.close()

    # -------------------------------------------------------------- helpers
    def _pose(self) -> tuple[float, float, float]:
        v = self.vehicle
        return float(v.position[0]), float(v.position[1]), float(v.heading)

    def _box(self, v, rgb=None) -> VehicleBox:
        paint = None
        if rgb is None:
            known = self._vehicle_rgb.get(id(v))
            if known is None:
                if self._colour_rng is None:
                    raise ResetNeededError("reset() must be called before the first step; call env.reset(seed=...).")
                _, albedo = draw_paint(self._colour_rng)  # one colour per vehicle and episode
                known = (paint_rgb(albedo), (float(albedo[0]), float(albedo[1]), float(albedo[2])))
                self._vehicle_rgb[id(v)] = known
            rgb, paint = known
        return VehicleBox(
            float(v.position[0]),
            float(v.position[1]),
            float(v.heading),
            float(v.LENGTH),
            float(v.WIDTH),
            rgb,
            paint=paint,
        )

    def _others(self) -> list[VehicleBox]:
        ego = self.vehicle
        return [self._box(v) for v in self._hw.road.vehicles if v is not ego]

    def _lane_state(self) -> tuple[float, float, float, float]:
        """(lateral offset, heading error, lane width, distance off the road surface)."""
        v = self.vehicle
        lane = self._hw.road.network.get_lane(self._hw.road.network.get_closest_lane_index(v.position, v.heading))
        s, lat = lane.local_coordinates(v.position)
        err = float(v.heading) - float(lane.heading_at(s))
        err = math.atan2(math.sin(err), math.cos(err))
        width = float(lane.width_at(s))
        # L1 distance beyond the nearest lane's edge (0 on the road surface).
        off = min(max(0.0, l.distance(v.position) - l.width_at(0.0) / 2) for l in self._hw.road.network.lanes_list())
        return float(lat), err, width, float(off)

    def _grip_state(self) -> dict[str, Any]:
        """``mu`` under the ego (None without friction) and ``sliding`` since the last call."""
        if self.grip is None:
            return {"mu": None, "sliding": False}
        slides = int(getattr(self.vehicle, "slides", 0))
        sliding, self._slides = slides > self._slides, slides
        return {"mu": float(self.vehicle.mu), "sliding": sliding}

    def _route_finished(self) -> bool:
        nodes = getattr(self._hw, "route_nodes", None)
        if not nodes:
            return False
        index = self.vehicle.lane_index
        lane = self._hw.road.network.get_lane(index)
        s, _ = lane.local_coordinates(self.vehicle.position)
        return index[1] == nodes[-1] and s >= lane.length - 10.0

    def render_scene(self, *, motion_m: float = 0.0) -> Frame:
        """What the camera's lens sees now, before the weather and the sensor: the
        renderer's :class:`~simroad.camera.render.Frame` of the current state (colour,
        exact road mask, depth, faces), the ground blurred by ``motion_m`` metres of
        travel during the exposure (the observations use the sensor's
        :meth:`~simroad.camera.sensor.Sensor.travel_m`). Draws nothing: the episode's
        frames are the same whether it is called or not."""
        if self.renderer is None:
            raise ResetNeededError("reset() must be called before the first step; call env.reset(seed=...).")
        return self.renderer.render(self._pose(), self._others(), motion_m=motion_m)

    def _observe(self, *, crashed: bool):
        speed = float(self.vehicle.speed)
        frame = self.render_scene(motion_m=self.sensor.travel_m(speed) if self.sensor is not None else 0.0)
        rgb = frame.rgb
        masks: dict[str, np.ndarray] = {}
        if self.weather is not None:
            yaw = math.atan2(
                math.sin(self.vehicle.heading - self._prev_heading), math.cos(self.vehicle.heading - self._prev_heading)
            )
            ctx = NoiseContext(
                camera=self.camera,
                depth=frame.depth,
                material=frame.material,
                vehicles=frame.vehicles,
                ego_speed=float(self.vehicle.speed),
                ego_yaw_rate=yaw / self.dt,
                dt=self.dt,
                time_s=self._time,
                face_id=getattr(frame, "face_id", None),  # the painter's Frame carries them
                faces=getattr(frame, "faces", None),
                motion_m=frame.motion_m,
            )
            rgb, masks = self.weather.apply(frame.rgb, ctx)
        if self.sensor is not None:  # the last stage of the camera, after the weather (docs/camera.md)
            # The renderer blurred the ground by the exposure's travel; the sensor
            # smears what stands on it.
            rgb = self.sensor.apply(rgb, speed_m_s=speed, depth=frame.depth, face_id=frame.face_id)
        lat, herr, width, off = self._lane_state()
        on_road = off == 0.0
        centring = 1.0 / (1.0 + lat * lat)
        rewards = {"lane_centering": centring, "on_road": float(on_road), "collision": float(crashed)}
        rewards["total"] = centring * float(on_road) - float(crashed)
        info = {
            "road_mask": frame.road_mask,
            "depth": frame.depth,
            "material": frame.material,
            "noise_masks": masks,
            "pose": np.array(self._pose()),
            "speed_m_s": float(self.vehicle.speed),
            "lateral_offset_m": lat,
            "heading_error_rad": herr,
            "lane_width_m": width,
            "offroad_distance_m": off,
            "on_road": on_road,
            "crashed": crashed,
            "time_s": self._time,
            "rewards": rewards,
            **self._grip_state(),
        }
        self._obs, self._info = rgb, info
        return rgb, info
