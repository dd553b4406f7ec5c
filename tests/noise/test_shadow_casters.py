"""Every shadow in a frame has its caster in the world, consistent in 3-D with the sun;
where the caster is in view and not hidden, the frame's ``material`` shows it.

Over scenarios, seeds, frames along the route and sun positions. The geometric part
runs on the world alone; the material part on the frames the camera paints
(``Frame.faces``, ``Frame.face_id``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from simroad.camera._painter import clip_near as _clip_near
from simroad.control import autopilot_action
from simroad.core.radiometry import srgb_to_linear
from simroad.envs import RoadCamEnv
from simroad.noise.context import FrameState, NoiseContext, resolve_frame
from simroad.noise.shadow import ShadowModel, rasterize_shadows

SUNS = [(0.0, 15.0), (90.0, 35.0), (200.0, 60.0), (300.0, 25.0)]
CASES = [("winding", 1), ("winding", 4), ("highway", 2), ("racetrack", 3), ("town", 5), ("highway", 7), ("winding", 9)]


def _frames(scenario: str, seed: int, n: int = 3, every: int = 6):
    env = RoadCamEnv(scenario=scenario, width=320, height=180, noise="shadow", severity=0.9, scenery=2.0)
    env.reset(seed=seed)
    for k in range(n * every):
        if k % every == 0:
            frame = env.renderer.render(env._pose(), env._others())
            yield env, frame
        env.step([autopilot_action(env.highway_env.road, env.vehicle)])
    env.close()


def _state(env, frame) -> FrameState:
    ctx = NoiseContext(camera=env.camera, depth=frame.depth, material=frame.material, vehicles=frame.vehicles)
    cam, depth, material, ground = resolve_frame(frame.rgb, ctx)
    return FrameState(srgb_to_linear(frame.rgb), cam, depth, material, ground, ctx)


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _visible_shadows(model: ShadowModel, state: FrameState):
    """(shadows, mesh, indices of the solid shadows with >= 5 shadowed ground pixels)."""
    sh = model.world_shadows(state)
    mesh = model._world.objects(*model.caster_box(state))
    seen = []
    for k in np.flatnonzero(sh.caster >= 0):
        cover = rasterize_shadows(sh.select([k]), state.camera) * state.ground
        if (cover > 0.5).sum() >= 5:
            seen.append(int(k))
    return sh, mesh, seen


@pytest.mark.parametrize(("scenario", "seed"), CASES)
def test_every_visible_shadow_has_its_caster_along_the_sun(scenario, seed):
    total = 0
    for env, frame in _frames(scenario, seed):
        model = env.weather.models["shadow"]
        for az, el in SUNS:
            model.set_sun(math.radians(az), math.radians(el))
            sh, mesh, seen = _visible_shadows(model, _state(env, frame))
            s_hat = np.array([math.cos(math.radians(az)), math.sin(math.radians(az))])
            cot = 1.0 / math.tan(math.radians(el))
            for k in seen:
                caster = sh.caster[k]
                faces = mesh.solid == caster
                assert faces.any(), f"shadow {k} has no caster solid {caster} in world.objects"
                v = mesh.vertices[faces].reshape(-1, 3)
                # A vertex at height z falls at p - z·cot(e)·ŝ (computed here independently).
                proj = v[:, :2] - (v[:, 2] * cot)[:, None] * s_hat
                hull = proj[ConvexHull(proj).vertices]
                poly = np.unique(sh.polys[k], axis=0)
                poly = poly[ConvexHull(poly).vertices]
                assert _area(poly) == pytest.approx(_area(hull), rel=0.02, abs=0.01)
                inside = [cv2.pointPolygonTest(poly.astype(np.float32), (float(x), float(y)), True) for x, y in hull]
                assert min(inside) > -0.02, (scenario, seed, az, el, caster)
                # The shadow lies away from the sun, by the caster's height.
                top = v[v[:, 2] >= v[:, 2].max() - 1e-6, :2].mean(axis=0)
                shift = proj[v[:, 2] >= v[:, 2].max() - 1e-6].mean(axis=0) - top
                np.testing.assert_allclose(shift, -v[:, 2].max() * cot * s_hat, atol=1e-6)
                total += 1
    assert total >= 20, f"only {total} visible shadows of scenery: the test says little"


def _face_pixels(cam, poly3: np.ndarray, normal: np.ndarray, shape) -> tuple[np.ndarray, np.ndarray]:
    """The pixels (bool (H, W), eroded by one) of a planar face, and the horizontal
    distance (m) from the camera to the face's point seen at each of them."""
    pc = _clip_near(cam.world_to_camera(poly3))
    mask = np.zeros(shape, np.uint8)
    if len(pc) >= 3:
        uv = cam.camera_to_image(pc)
        cv2.fillConvexPoly(mask, np.round(np.clip(uv, -1e4, 1e4) * 16).astype(np.int32), 1, cv2.LINE_8, 4)
    pix = cv2.erode(mask, np.ones((3, 3), np.uint8)) > 0
    rows, cols = np.nonzero(pix)
    origin = cam.world_to_camera(np.zeros((1, 3)))[0]
    rot = cam.world_to_camera(np.eye(3)) - origin  # rows: world axes in camera coordinates
    centre = np.array([*cam.position_world, cam.config.mount_height_m])
    rays = np.column_stack([cols, rows, np.ones(len(rows))]) @ np.linalg.inv(cam.K).T @ rot.T  # world directions
    t = float(normal @ (poly3[0] - centre)) / (rays @ normal)
    hit = centre + t[:, None] * rays
    return pix, np.hypot(hit[:, 0] - centre[0], hit[:, 1] - centre[1])


@pytest.mark.parametrize(("scenario", "seed"), CASES)
def test_casters_in_view_are_in_the_material_map(scenario, seed):
    """For every caster of a visible shadow and each of its faces turned to the camera,
    the face's pixels where nothing nearer is seen (the frame's depth is not below
    the face's own horizontal distance there, 1 % and 0.1 m of slack) must carry
    the caster's material code: 90 % of every face, 99 % of all pixels checked.
    """
    checked = good = total = 0
    for env, frame in _frames(scenario, seed, n=2):
        assert frame.faces is not None and frame.face_id is not None
        model = env.weather.models["shadow"]
        cam = env.camera
        cpos = np.array([*cam.position_world, cam.config.mount_height_m])
        for az, el in SUNS[:2]:
            model.set_sun(math.radians(az), math.radians(el))
            sh, mesh, seen = _visible_shadows(model, _state(env, frame))
            for caster in {int(sh.caster[k]) for k in seen}:
                for f in np.flatnonzero(mesh.solid == caster):
                    poly = mesh.vertices[f, : mesh.counts[f]]
                    if np.dot(mesh.normal[f], cpos - poly.mean(axis=0)) <= 0:
                        continue  # turned away from the camera
                    if np.hypot(*(poly[:, :2] - cpos[:2]).T).min() > cam.config.max_range_m:
                        continue  # beyond the camera's range: the camera draws no face there
                    pix, dist = _face_pixels(cam, poly, mesh.normal[f], frame.material.shape)
                    shown = frame.depth[pix] >= 0.99 * dist - 0.1  # nothing nearer there
                    if shown.sum() < 20:
                        continue
                    ok = frame.material[pix][shown] == mesh.material[f]
                    # A face touching another solid (a sign's post behind its plate, a
                    # crown brushing a wall) shares a few pixels of equal depth with it.
                    assert ok.mean() >= 0.9, (scenario, seed, caster, f, ok.mean(), np.unique(frame.material[pix]))
                    checked += 1
                    good += int(ok.sum())
                    total += len(ok)
    assert checked >= 10 and good >= 0.99 * total, (checked, good, total)
