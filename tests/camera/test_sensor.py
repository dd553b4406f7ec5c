"""The camera sensor: identity, seeding, and each effect against a case worked by hand."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from simroad.camera import CameraConfig, PinholeCamera, Sensor, SensorParams
from simroad.camera._sensor_ops import NoiseTile, motion_blur_scale, radial_motion_blur
from simroad.camera.exposure import ChromaScratch, metered_mean, process_chroma
from simroad.camera.sensor import apply_sensor
from simroad.core.radiometry import GAMMA, linear_to_srgb, srgb_to_linear
from simroad.envs import RoadCamConfig, RoadCamEnv
from simroad.errors import SimroadError

CAM = PinholeCamera(CameraConfig(width=64, height=48, hfov_deg=90.0, pitch_deg=0.0))
OFF = SensorParams.none()


def _frame(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (48, 64, 3), dtype=np.uint8)


def test_identity_params_are_bit_identical():
    img = _frame()
    out, _ = apply_sensor(img, OFF, CAM, np.random.default_rng(0), speed_m_s=30.0)
    assert out.dtype == np.uint8 and np.array_equal(out, img) and out is not img


def test_same_seed_same_frames_different_seed_different_noise():
    img = _frame()

    def run(seed):
        s = Sensor(SensorParams(), CAM)
        s.reset(np.random.default_rng(seed))
        return [s.apply(img, speed_m_s=20.0) for _ in range(3)]

    a, b, c = run(1), run(1), run(2)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not any(np.array_equal(x, y) for x, y in zip(a, c, strict=True))
    assert not np.array_equal(a[1], a[2])  # a new noise window every frame


def test_input_not_mutated():
    img = _frame()
    before = img.copy()
    apply_sensor(img, SensorParams(jpeg_quality=50), CAM, np.random.default_rng(0), speed_m_s=30.0)
    assert np.array_equal(img, before)


@pytest.mark.parametrize("code", [60, 128, 200])
def test_noise_mean_and_variance_follow_emva_1288(code):
    # Flat grey of linear radiance L at ev=0: mean signal mu = L * FW electrons;
    # EMVA 1288: variance = mu (shot) + sigma_read^2, in electrons.
    fw, read = 1000.0, 20.0
    p = dataclasses.replace(OFF, shot_noise=True, read_noise_e=read, full_well_e=fw, adc_bits=16)
    cam = PinholeCamera(CameraConfig(width=400, height=300, pitch_deg=0.0))
    img = np.full((300, 400, 3), code, np.uint8)
    lin_in = float(srgb_to_linear(img)[0, 0, 0])
    mu = lin_in * fw
    sensor = Sensor(p, cam)
    sensor.reset(np.random.default_rng(0))
    out = sensor.apply(img)
    electrons = srgb_to_linear(out).astype(np.float64) * fw  # back through the sRGB encoding
    # 8-bit output quantisation adds step^2/12 (step = electrons per output code here).
    step = (float(srgb_to_linear(np.full((1, 1, 3), code + 1, np.uint8))[0, 0, 0]) - lin_in) * fw
    assert electrons.mean() == pytest.approx(mu, rel=0.01)
    assert electrons.std() == pytest.approx(math.sqrt(mu + read**2 + step**2 / 12), rel=0.04)


def test_noise_tile_windows_are_uncorrelated_between_frames():
    rng = np.random.default_rng(3)
    tile = NoiseTile(48, 64, rng)
    frames = []
    for _ in range(60):
        view, sign = tile.window(rng)
        assert view.shape == (48, 64, 3) and sign in (-1.0, 1.0)
        frames.append(sign * view.ravel())
    stack = np.array(frames)
    corr = np.corrcoef(stack)
    off = corr[~np.eye(len(frames), dtype=bool)]
    assert np.abs(off).max() < 0.06  # n = 9216 samples: sd of r ~ 0.01
    # Within a frame the field is i.i.d. (no tiling inside a frame): unit variance,
    # no correlation at a lag of one pixel.
    f = stack[0].reshape(48, 64, 3)
    assert f.std() == pytest.approx(1.0, abs=0.03)
    assert abs(np.corrcoef(f[:, 1:].ravel(), f[:, :-1].ravel())[0, 1]) < 0.05


@pytest.mark.parametrize("exponent", [4.0, 2.0])
def test_vignetting_corner_is_cos_n_of_field_angle(exponent):
    # 64 x 48 at 90 deg hfov: f = 32 px; centre (31.5, 23.5); corner pixel (0, 0)
    # is r = hypot(31.5, 23.5) px off axis, field angle atan(r / f).
    p = dataclasses.replace(OFF, vignetting=True, vignetting_exponent=exponent, adc_bits=16)
    img = linear_to_srgb(np.full((48, 64, 3), 0.5, np.float32))
    out, _ = apply_sensor(img, p, CAM, np.random.default_rng(0))
    ratio = srgb_to_linear(out)[0, 0, 0] / srgb_to_linear(img)[0, 0, 0]
    theta = math.atan(math.hypot(31.5, 23.5) / 32.0)
    assert ratio == pytest.approx(math.cos(theta) ** exponent, abs=0.01)


def test_auto_exposure_settles_then_follows_a_step_at_its_rate():
    # The meter reads the encoded output; with the identity response a uniform frame
    # of linear value x at exposure ev reads (x 2**ev)**(1/GAMMA).
    p = dataclasses.replace(OFF, auto_exposure=True, ae_target_mean=0.4, ae_rate=0.3, adc_bits=16)
    sensor = Sensor(p, CAM)
    sensor.reset(np.random.default_rng(0))
    bright = linear_to_srgb(np.full((48, 64, 3), 0.4, np.float32))
    out = sensor.apply(bright)  # the first frame is settled at the target (bisection to 1/32 EV)
    assert float(out.mean()) / 255.0 == pytest.approx(0.4, abs=0.006)
    assert sensor.ev == pytest.approx(GAMMA * math.log2(0.4) - math.log2(0.4), abs=0.02)
    dark = linear_to_srgb(np.full((48, 64, 3), 0.05, np.float32))  # entering a shadow
    lin = float(srgb_to_linear(dark).mean())

    def error(ev: float) -> float:  # in stops of exposure
        return GAMMA * math.log2(0.4) - math.log2(lin) - ev

    first = error(sensor.ev)
    errors = []
    for _ in range(30):
        out = sensor.apply(dark)
        errors.append(error(sensor.ev))
    # One frame of latency, then the error shrinks by (1 - rate) per frame:
    # a time constant of -1 / ln(1 - rate) frames. The meter reads the 8-bit output: the
    # dark frame's level (39 of 255) is known to half a code, which moves a step by up to
    # rate * GAMMA * log2(1 + 0.5 / 39) stops.
    quantum = 0.3 * GAMMA * math.log2(1 + 0.5 / 39)
    assert errors[0] == pytest.approx(first * 0.7, abs=quantum)
    assert errors[1] == pytest.approx(first * 0.7**2, abs=2 * quantum)
    assert abs(errors[-1]) < GAMMA * math.log2(1 + 0.5 / 102)  # settled to half a code at the target (102)
    assert float(out.mean()) / 255.0 == pytest.approx(0.4, abs=0.01)


def test_the_meter_weighs_the_centre_and_lets_highlights_clip():
    h, w = 36, 64
    flat = np.full((h, w, 3), 100, np.uint8)
    assert metered_mean(flat) == pytest.approx(100 / 255, abs=1e-6)
    centre, corner = flat.copy(), flat.copy()
    centre[14:22, 28:36] = 200
    corner[:8, :8] = 200
    assert metered_mean(centre) > metered_mean(corner) + 0.01  # the centre counts more than a corner
    sky = np.full((h, w, 3), 50, np.uint8)
    sky[:16] = 250  # a sky at the top of the frame, past the highlight level
    grey = sky.copy()
    grey[:16] = 180  # the same sky below it: it counts fully
    plain = float(sky.mean()) / 255
    assert metered_mean(sky) < plain - 0.05  # the highlights count less than their share
    assert metered_mean(grey) == pytest.approx(float(grey.mean()) / 255, abs=0.03)


def test_chroma_stage_by_hand_on_a_flat_colour():
    # Flat (100, 150, 200): luma 0.299*100 + 0.587*150 + 0.114*200 = 140.75 -> 141 (OpenCV
    # rounds); chroma (-41, 9, 59), unchanged by the Gaussian on a flat field (to float32's
    # last bits); times 1.25 and back onto 141: (89.75, 152.25, 214.75) -> (90, 152, 215).
    out = np.empty((20, 30, 3), np.uint8)
    out[:] = (100, 150, 200)
    process_chroma(out, 1.25, 2.0)
    assert np.array_equal(out.reshape(-1, 3), np.tile([90, 152, 215], (600, 1)))
    out[:] = (10, 150, 250)  # chroma x 3 saturates at 0 and 255 instead of wrapping
    process_chroma(out, 3.0, 2.0)
    assert out[0, 0, 0] == 0 and out[0, 0, 2] == 255


def _chroma_reference(out: np.ndarray, factor: float, px: float) -> np.ndarray:
    """The chroma stage step by step in numpy's float32 operations."""
    grey = cv2.cvtColor(out, cv2.COLOR_RGB2GRAY).astype(np.float32)[:, :, None]
    chroma = out.astype(np.float32) - grey
    chroma = cv2.GaussianBlur(chroma, (0, 0), px, borderType=cv2.BORDER_REFLECT)
    return np.rint(np.clip(chroma * np.float32(factor) + grey, 0.0, 255.0)).astype(np.uint8)


@pytest.mark.parametrize("seed", range(4))
def test_chroma_stage_is_the_numpy_float32_steps_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    scratch = ChromaScratch(48, 64)
    for _ in range(5):
        img = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
        img = cv2.GaussianBlur(img, (0, 0), float(rng.uniform(0.0, 3.0))) if rng.random() < 0.5 else img
        factor, px = float(rng.uniform(0.3, 2.5)), float(rng.uniform(0.3, 3.0))
        expected = _chroma_reference(img, factor, px)
        out = img.copy()
        process_chroma(out, factor, px, scratch=scratch)
        assert np.array_equal(out, expected)
    wide = rng.integers(0, 256, (48, 128, 3), dtype=np.uint8)
    view = wide[:, ::2]  # not contiguous: worked on a copy, written back
    expected = _chroma_reference(np.ascontiguousarray(view), 1.3, 1.5)
    process_chroma(view, 1.3, 1.5)
    assert np.array_equal(view, expected)


@pytest.mark.parametrize("roi_top", [0.0, 0.5])
def test_auto_exposure_meters_its_window(roi_top):
    # Bright sky above, darker road below: metering the lower half exposes the road at
    # the target and lets the sky saturate; metering all of it holds the meter's
    # reading of the whole frame at the target.
    p = dataclasses.replace(OFF, auto_exposure=True, ae_target_mean=0.4, adc_bits=16, ae_roi_top=roi_top)
    sensor = Sensor(p, CAM)
    sensor.reset(np.random.default_rng(0))
    lin = np.full((48, 64, 3), 0.05, np.float32)
    lin[:24] = 0.6
    out = sensor.apply(linear_to_srgb(lin))
    top = int(roi_top * 48)
    assert metered_mean(out, top) == pytest.approx(0.4, abs=0.01)
    if roi_top:
        assert float(out[24:].mean()) / 255 == pytest.approx(0.4, abs=0.01)  # the road at the target
        assert float(srgb_to_linear(out[:24]).mean()) == pytest.approx(1.0, abs=0.01)  # the sky saturates
    else:  # between the exposures that would put either half alone at the target
        assert float(out[24:].mean()) / 255 < 0.4 < float(out[:24].mean()) / 255


def test_white_balance_is_drawn_per_episode_and_tints_the_frame():
    p = dataclasses.replace(OFF, white_balance_error=0.1, adc_bits=16)
    grey = linear_to_srgb(np.full((48, 64, 3), 0.2, np.float32))
    gains = []
    for seed in range(40):
        sensor = Sensor(p, CAM)
        sensor.reset(np.random.default_rng(seed))
        wb = sensor.white_balance
        assert wb is not None and wb[1] == 1.0
        out = srgb_to_linear(sensor.apply(grey)).reshape(-1, 3).mean(axis=0)
        np.testing.assert_allclose(out / out[1], wb, rtol=0.01)  # the frame carries the gains
        gains.append(np.log(wb[[0, 2]]))
    g = np.array(gains)
    assert abs(g.mean()) < 0.05 and 0.06 < g.std() < 0.14  # log-gains ~ N(0, 0.1)
    again = Sensor(p, CAM)
    again.reset(np.random.default_rng(39))
    np.testing.assert_array_equal(again.white_balance, wb)  # reproducible per seed
    neutral = Sensor(dataclasses.replace(p, white_balance_error=0.0), CAM)
    neutral.reset(np.random.default_rng(0))
    assert neutral.white_balance is None


def test_auto_exposure_stops_at_its_limits():
    p = dataclasses.replace(OFF, auto_exposure=True, ev_max=2.0, ae_rate=1.0)
    sensor = Sensor(p, CAM)
    sensor.reset(np.random.default_rng(0))
    for _ in range(5):
        sensor.apply(np.full((48, 64, 3), 5, np.uint8))
    assert sensor.ev == 2.0
    sensor.reset(np.random.default_rng(0))
    assert sensor.ev == 0.0


def test_motion_blur_scale_matches_ground_flow_by_hand():
    # Zero pitch: row y sees the ground at Z = f h / (y - cy) on the centre column;
    # over the exposure it moves by f h (1 / (Z - vT) - 1 / Z) pixels.
    f, h, cy = 32.0, 1.3, 23.5
    travel = 20.0 * 0.01
    s = motion_blur_scale(CAM.depth, focal_px=f, cx=31.5, travel_m=travel)
    y, x = 40, 31  # near the centre column: bearing ~ 0
    z = float(CAM.depth[y, x]) * 32.0 / math.hypot(32.0, 0.5)
    assert s[y, x] * (y - cy) == pytest.approx(f * h * (1.0 / (z - travel) - 1.0 / z), rel=1e-4)
    assert np.all(s[:24] == 0.0)  # the sky does not move
    assert np.all(motion_blur_scale(CAM.depth, focal_px=f, cx=31.5, travel_m=0.0) == 0.0)
    s2 = motion_blur_scale(CAM.depth, focal_px=f, cx=31.5, travel_m=2 * travel)
    assert s2[y, x] / s[y, x] == pytest.approx(2.0 * (z - travel) / (z - 2 * travel), rel=1e-4)


def test_radial_blur_smears_a_point_away_from_the_focus_of_expansion():
    # A point at (col 50, row 40) with e = (31.5, 23.5): the flow is diagonal, the
    # smear spreads along (p - e) over s |p - e| pixels, its centroid half-way.
    lin = np.zeros((48, 64, 3), np.float32)
    lin[40, 50] = 1.0
    scale = np.full((48, 64), 0.3, np.float32)
    out = radial_motion_blur(lin.copy(), scale, cx=31.5, foe_row=23.5)
    w = out[..., 0].astype(np.float64)
    rows, cols = np.mgrid[0:48, 0:64]
    cy_, cx_ = (w * rows).sum() / w.sum(), (w * cols).sum() / w.sum()
    # Pixel p gathers from p + t (p - e) s: the light of the point reaches the pixels
    # q with q + t (q - e) s = point, i.e. towards the focus of expansion.
    t = np.linspace(0.0, 1.0, 1001)
    q = (np.array([50.0, 40.0]) + t[:, None] * 0.3 * np.array([31.5, 23.5])) / (1.0 + 0.3 * t[:, None])
    assert cx_ == pytest.approx(q[:, 0].mean(), abs=0.35)
    assert cy_ == pytest.approx(q[:, 1].mean(), abs=0.35)
    # The smear lies along the radial line (no vertical-only streak).
    assert (cx_ - 50.0) / (cy_ - 40.0) == pytest.approx((50 - 31.5) / (40 - 23.5), rel=0.1)
    flat = np.full((48, 64, 3), 0.3, np.float32)
    np.testing.assert_allclose(radial_motion_blur(flat.copy(), scale, cx=31.5, foe_row=23.5), flat, atol=1e-6)
    still = radial_motion_blur(lin.copy(), np.zeros((48, 64), np.float32), cx=31.5, foe_row=23.5)
    assert np.array_equal(still, lin)


def test_blur_grows_with_speed():
    img = linear_to_srgb(np.random.default_rng(0).random((48, 64, 3), dtype=np.float32))
    p = dataclasses.replace(OFF, motion_blur=True, adc_bits=16)
    diffs = []
    for v in (0.0, 10.0, 40.0):
        out, _ = apply_sensor(img, p, CAM, np.random.default_rng(0), speed_m_s=v)
        diffs.append(np.abs(out.astype(int) - img.astype(int))[30:].mean())
    assert diffs[0] < 0.6 < diffs[1] < diffs[2]


def test_jpeg_error_falls_with_quality():
    img = _frame()
    errors = []
    for q in (10, 50, 95):
        on, _ = apply_sensor(img, dataclasses.replace(OFF, jpeg_quality=q), CAM, np.random.default_rng(0))
        assert on.shape == img.shape and on.dtype == np.uint8
        errors.append(np.abs(on.astype(int) - img.astype(int)).mean())
    assert errors[0] > errors[1] > errors[2] > 0


_BAD = {
    bool: ["yes", 2, None],
    float: [-1e9, float("nan"), 1e9, "x", None],
    int: [7, 17, 5.5, "x", None],
    "jpeg": [0, 101, 5.5, "high"],
}


@pytest.mark.parametrize("field", [f.name for f in dataclasses.fields(SensorParams)])
def test_every_bad_field_is_refused_by_name(field):
    default = getattr(SensorParams(), field)
    bad = _BAD["jpeg"] if field == "jpeg_quality" else _BAD[type(default)]
    for value in bad:
        with pytest.raises(SimroadError, match=field):
            SensorParams(**{field: value})


def test_sensor_requires_reset():
    with pytest.raises(SimroadError, match="reset"):
        Sensor(SensorParams(), CAM).apply(_frame())


def test_camera_effects_on_by_default():
    assert RoadCamConfig().camera_effects is True
    assert RoadCamConfig().sensor_params == SensorParams()


@pytest.mark.parametrize("effects", [True, SensorParams(jpeg_quality=60)])
def test_env_with_camera_effects_runs(effects):
    env = RoadCamEnv(width=96, height=64, camera_effects=effects)
    plain = RoadCamEnv(width=96, height=64, camera_effects=False)
    obs, _ = env.reset(seed=4)
    ref, _ = plain.reset(seed=4)
    for _ in range(3):
        obs, *_ = env.step(np.array([0.0], np.float32))
        ref, *_ = plain.step(np.array([0.0], np.float32))
        assert obs.dtype == np.uint8 and env.observation_space.contains(obs)
    assert not np.array_equal(obs, ref)
    with pytest.raises(SimroadError, match="camera_effects"):
        RoadCamEnv(camera_effects="on")


def test_env_without_camera_effects_is_the_perfect_pinhole():
    env = RoadCamEnv(width=96, height=64, camera_effects=False)
    obs, info = env.reset(seed=7)
    assert env.sensor is None
    for _ in range(3):
        frame = env.renderer.render(env._pose(), env._others())
        assert np.array_equal(obs, frame.rgb) and np.array_equal(info["road_mask"], frame.road_mask)
        obs, _, _, _, info = env.step(np.array([0.1], np.float32))


def test_env_same_seed_same_frames_with_effects():
    a, b = RoadCamEnv(width=96, height=64), RoadCamEnv(width=96, height=64)
    oa, _ = a.reset(seed=5)
    ob, _ = b.reset(seed=5)
    for _ in range(3):
        assert np.array_equal(oa, ob)
        oa, *_ = a.step(np.array([0.05], np.float32))
        ob, *_ = b.step(np.array([0.05], np.float32))
