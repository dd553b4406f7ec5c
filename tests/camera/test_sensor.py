"""The camera sensor: identity, seeding, and each effect against a case worked by hand."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from simroad._validation import SimroadError
from simroad.camera import CameraConfig, PinholeCamera, Sensor, SensorParams
from simroad.camera.sensor import (
    apply_sensor,
    motion_blur_lengths,
    vertical_motion_blur,
)
from simroad.envs import RoadCamEnv
from simroad.noise.radiometry import linear_to_srgb, srgb_to_linear

CAM = PinholeCamera(CameraConfig(width=64, height=48, hfov_deg=90.0, pitch_deg=0.0))
OFF = SensorParams.none()


def _frame(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (48, 64, 3), dtype=np.uint8)


def test_identity_params_are_bit_identical():
    img = _frame()
    out, _ = apply_sensor(img, OFF, CAM, np.random.default_rng(0), speed_m_s=30.0)
    assert out.dtype == np.uint8 and np.array_equal(out, img) and out is not img


def test_same_seed_same_output_different_seed_differs():
    img, p = _frame(), SensorParams(jpeg_quality=80)
    a, _ = apply_sensor(img, p, CAM, np.random.default_rng(1), speed_m_s=20.0)
    b, _ = apply_sensor(img, p, CAM, np.random.default_rng(1), speed_m_s=20.0)
    c, _ = apply_sensor(img, p, CAM, np.random.default_rng(2), speed_m_s=20.0)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_input_not_mutated():
    img = _frame()
    before = img.copy()
    apply_sensor(img, SensorParams(jpeg_quality=50), CAM, np.random.default_rng(0), speed_m_s=30.0)
    assert np.array_equal(img, before)


def test_shot_and_read_noise_variance_matches_poisson_gaussian_model():
    # Flat grey of linear radiance L at ev=0: mean signal mu = L * FW electrons;
    # EMVA 1288: variance = mu (shot) + sigma_read^2, in electrons.
    fw, read = 1000.0, 20.0
    p = dataclasses.replace(OFF, shot_noise=True, read_noise_e=read, full_well_e=fw)
    cam = PinholeCamera(CameraConfig(width=400, height=300, pitch_deg=0.0))
    img = np.full((300, 400, 3), 128, np.uint8)
    lin_in = float(srgb_to_linear(img)[0, 0, 0])
    mu = lin_in * fw
    expected_sd_e = math.sqrt(mu + read**2)
    out, _ = apply_sensor(img, p, cam, np.random.default_rng(0))
    # Back to electrons through the (invertible) sRGB encoding.
    electrons = srgb_to_linear(out).astype(np.float64) * fw
    assert electrons.mean() == pytest.approx(mu, rel=0.01)
    # 8-bit quantisation adds step^2/12 (step ~ fw * d(lin)/d(code) at this level).
    step = (float(srgb_to_linear(np.full((1, 1, 3), 129, np.uint8))[0, 0, 0]) - lin_in) * fw
    assert electrons.std() == pytest.approx(math.sqrt(expected_sd_e**2 + step**2 / 12), rel=0.03)
    assert electrons.std() > 1.5 * math.sqrt(mu)  # the read noise is really there


def test_vignetting_corner_is_cos4_of_field_angle():
    # 64 x 48 at 90 deg hfov: f = 32 px; centre (31.5, 23.5); corner pixel (0, 0)
    # is r = hypot(31.5, 23.5) px off axis, field angle atan(r / f).
    p = dataclasses.replace(OFF, vignetting=True)
    lin = np.full((48, 64, 3), 0.5, np.float32)
    img = linear_to_srgb(lin)
    out, _ = apply_sensor(img, p, CAM, np.random.default_rng(0))
    ratio = srgb_to_linear(out)[0, 0, 0] / srgb_to_linear(img)[0, 0, 0]
    theta = math.atan(math.hypot(31.5, 23.5) / 32.0)
    assert ratio == pytest.approx(math.cos(theta) ** 4, abs=0.01)
    assert math.cos(theta) ** 4 < 0.5  # a corner that is really darker


@pytest.mark.parametrize("level", [0.02, 0.8])
def test_auto_exposure_converges_at_its_rate(level):
    p = dataclasses.replace(OFF, auto_exposure=True, ae_target_mean=0.18, ae_rate=0.3)
    sensor = Sensor(p, CAM)
    sensor.reset(np.random.default_rng(0))
    img = linear_to_srgb(np.full((48, 64, 3), level, np.float32))
    lin = float(srgb_to_linear(img).mean())
    errors = []
    for _ in range(25):
        out = sensor.apply(img)
        errors.append(math.log2(0.18) - math.log2(min(lin * 2.0**sensor.ev, 1.0)))
    # Before saturation matters, the log2 error shrinks by (1 - rate) per frame.
    first = math.log2(0.18 / lin)
    assert errors[0] == pytest.approx(first * 0.7, rel=1e-3)
    assert errors[1] == pytest.approx(first * 0.7**2, rel=1e-3)
    assert abs(errors[-1]) < 0.01
    assert float(srgb_to_linear(out).mean()) == pytest.approx(0.18, rel=0.05)


def test_auto_exposure_stops_at_its_limits():
    p = dataclasses.replace(OFF, auto_exposure=True, ev_max=2.0, ae_rate=1.0)
    sensor = Sensor(p, CAM)
    sensor.reset(np.random.default_rng(0))
    for _ in range(5):
        sensor.apply(np.full((48, 64, 3), 5, np.uint8))
    assert sensor.ev == 2.0
    sensor.reset(np.random.default_rng(0))
    assert sensor.ev == 0.0


def test_motion_blur_length_matches_ground_flow_by_hand():
    # Zero pitch: row y sees the ground at Z0 = f h / (y - cy). f = 32, h = 1.3.
    f, h, cy = 32.0, 1.3, 23.5
    v, t = 20.0, 0.01
    lengths = motion_blur_lengths(48, focal_px=f, mount_height_m=h, horizon_row=cy, speed_m_s=v, exposure_s=t)
    y = 40
    z0 = f * h / (y - cy)
    assert lengths[y] == pytest.approx(f * h * (1.0 / (z0 - v * t) - 1.0 / z0))
    assert np.all(lengths[:24] == 0.0)  # sky does not move
    zero = motion_blur_lengths(48, focal_px=f, mount_height_m=h, horizon_row=cy, speed_m_s=0.0, exposure_s=t)
    assert np.all(zero == 0.0)
    # With a depth map the row's distance comes from it.
    depth = np.full((48, 64), np.inf, np.float32)
    depth[30] = 5.0
    d = motion_blur_lengths(48, focal_px=f, mount_height_m=h, horizon_row=cy, speed_m_s=v, exposure_s=t, depth=depth)
    assert d[30] == pytest.approx(f * h * (1.0 / (5.0 - v * t) - 1.0 / 5.0), rel=1e-6)
    assert np.count_nonzero(d) == 1


def test_vertical_blur_spreads_a_line_over_its_length():
    lin = np.zeros((20, 4, 3), np.float32)
    lin[5] = 1.0
    lengths = np.full(20, 4.0)
    out = vertical_motion_blur(lin, lengths)
    # A pixel averages the 4 rows above it (itself included): rows 5..8 see the line.
    np.testing.assert_allclose(out[:, 0, 0], [0.25 if 5 <= r <= 8 else 0.0 for r in range(20)], atol=1e-6)
    assert out.sum() == pytest.approx(lin.sum())
    assert np.array_equal(vertical_motion_blur(lin, np.zeros(20)), lin)


def test_jpeg_changes_the_frame_only_when_on():
    img = _frame()
    on, _ = apply_sensor(img, dataclasses.replace(OFF, jpeg_quality=50), CAM, np.random.default_rng(0))
    off, _ = apply_sensor(img, OFF, CAM, np.random.default_rng(0))
    assert not np.array_equal(on, img) and np.array_equal(off, img)
    assert on.shape == img.shape and on.dtype == np.uint8


_BAD = {bool: ["yes", 2, None], float: [-1e9, float("nan"), 1e9, "x", None], "jpeg": [0, 101, 5.5, "high"]}


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


@pytest.mark.parametrize("effects", [True, SensorParams(jpeg_quality=60)])
def test_env_with_camera_effects_runs(effects):
    env = RoadCamEnv(width=96, height=64, camera_effects=effects)
    plain = RoadCamEnv(width=96, height=64)
    obs, _ = env.reset(seed=4)
    ref, _ = plain.reset(seed=4)
    for _ in range(3):
        obs, *_ = env.step(np.array([0.0], np.float32))
        ref, *_ = plain.step(np.array([0.0], np.float32))
        assert obs.dtype == np.uint8 and env.observation_space.contains(obs)
    assert not np.array_equal(obs, ref)
    with pytest.raises(SimroadError, match="camera_effects"):
        RoadCamEnv(camera_effects="on")


def test_env_without_camera_effects_is_bit_identical():
    a, b = (
        RoadCamEnv(noise="rain", width=96, height=64),
        RoadCamEnv(noise="rain", width=96, height=64, camera_effects=False),
    )
    oa, ia = a.reset(seed=7)
    ob, ib = b.reset(seed=7)
    for _ in range(4):
        assert np.array_equal(oa, ob) and np.array_equal(ia["road_mask"], ib["road_mask"])
        assert ia["lateral_offset_m"] == ib["lateral_offset_m"]
        oa, _, _, _, ia = a.step(np.array([0.1], np.float32))
        ob, _, _, _, ib = b.step(np.array([0.1], np.float32))
    assert b.sensor is None
