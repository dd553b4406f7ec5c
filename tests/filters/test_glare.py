"""The improved light filter (simroad.filters.glare) against a lobe worked by hand."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad import SimroadError
from simroad.experiments.frames import collect_frames
from simroad.filters import remove_glare
from simroad.filters._common import camera_to_linear as _decode
from simroad.filters._common import linear_to_camera as _encode
from simroad.filters.glare import _fit_tint, sun_tint

H, W = 180, 320
SUN = np.array([1.0, 0.8, 0.45], np.float32)  # Rayleigh-reddened sun at ~13 degrees


def _clean_signal() -> np.ndarray:
    """Linear camera signal: bright sky, grey asphalt (0.10) between grey shoulders (0.30)
    wider than the filter's ``wide`` opening (107 px), as the filter assumes."""
    y = np.full((H, W, 3), 0.10, np.float32)
    y[:, :110] = 0.30
    y[:, -110:] = 0.30
    y[:75] = 0.6
    return y


def _glare_signal(peak: float) -> tuple[np.ndarray, np.ndarray]:
    """The clean signal plus an additive sun-coloured lobe on the ground (rows >= 90),
    exposed as the camera's auto-exposure would meter it (the same mean over the whole
    frame, sky included, as ``remove_glare``'s default ``metering_top=0`` assumes)."""
    clean = _clean_signal()
    col = np.arange(W, dtype=np.float32)
    lobe = np.zeros((H, W), np.float32)
    lobe[90:] = peak * np.exp(-0.5 * ((col - 160.0) / 15.0) ** 2)[None, :]
    lit = clean + lobe[..., None] * SUN
    exposure = clean.mean() / lit.mean()
    return lit * exposure, lobe


def _display(y: np.ndarray) -> np.ndarray:
    return np.stack([_encode(y[..., c], 1.0) for c in range(3)], axis=-1)


def test_decode_inverts_the_sensors_response():
    from simroad.camera._sensor_ops import adc_response_lut
    from simroad.core.radiometry import CAMERA_SHOULDER, CAMERA_TONE_GAMMA

    full = 2**12 - 1
    table = adc_response_lut(12, CAMERA_SHOULDER, CAMERA_TONE_GAMMA)  # digital number -> 8-bit output
    d = np.arange(0, full, 7)
    code = table[d].astype(np.int64)
    back = _decode(code.astype(np.float32) / 255.0, 1.0)
    # within the output's 8-bit step there (the widest of its two sides: large in the shoulder)
    up = _decode(np.minimum(code + 1, 255).astype(np.float32) / 255.0, 1.0) - back
    down = back - _decode(np.maximum(code - 1, 0).astype(np.float32) / 255.0, 1.0)
    assert np.all(np.abs(back - d / full) <= np.maximum(up, down) + 1e-6)


def test_decode_inverts_encode():
    y = np.linspace(0.0, 1.0, 101, dtype=np.float32)
    np.testing.assert_allclose(_decode(_encode(y, 1.0), 1.0), y, atol=1e-5)


def test_remove_glare_recovers_the_clean_frame_under_a_sun_coloured_lobe():
    clean = _display(_clean_signal())
    # bright enough to move the whole frame's exposure, not so bright that the lobe's core
    # clips over a wide band (a clipped core keeps no record of the light it took)
    lit, lobe = _glare_signal(peak=1.5)
    img = _display(lit)
    out, mask = remove_glare(img)
    on = lobe > 0.02
    before = np.abs(img - clean)[on].mean()
    assert before > 0.1  # the lobe and the exposure change the frame
    assert np.abs(out - clean)[on].mean() < 0.35 * before  # quarter-resolution lobe: not exact
    # the road beside the lobe was darkened by the exposure; it comes back
    beside = (slice(100, 180), slice(20, 90))
    assert np.abs(img[beside] - clean[beside]).mean() > 0.04
    assert np.abs(out[beside] - clean[beside]).max() < 0.2 * np.abs(img[beside] - clean[beside]).mean()
    assert mask[120:, 160].all() and not mask[:80].any() and not mask[:, :20].any()


def test_remove_glare_without_a_lobe_is_identity():
    rng = np.random.default_rng(0)
    y = _clean_signal() * rng.uniform(0.9, 1.1, (H, W, 1)).astype(np.float32)  # asphalt grain
    u8 = (_display(y) * 255 + 0.5).astype(np.uint8)
    out, mask = remove_glare(u8)
    assert not mask.any()
    np.testing.assert_array_equal(out, u8)


def test_remove_glare_leaves_the_input_alone_and_keeps_dtype():
    u8 = (_display(_glare_signal(2.5)[0]) * 255 + 0.5).astype(np.uint8)
    before = u8.copy()
    out, mask = remove_glare(u8)
    assert out.dtype == np.uint8 and out.shape == u8.shape and mask.any()
    np.testing.assert_array_equal(u8, before)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fine": 4}, "fine: expected an odd window size, got 4. Use 5."),
        ({"wide": 1}, "wide"),
        ({"min_lift": 0.0}, "min_lift"),
        ({"min_excess": 0.0}, "min_excess"),
        ({"top": 1.0}, "top"),
        ({"metering_top": -0.1}, "metering_top"),
        ({"shoulder": -1.0}, "shoulder"),
    ],
)
def test_remove_glare_rejects_bad_parameters(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        remove_glare(np.zeros((20, 20, 3), np.uint8), **kwargs)


def test_the_sun_colour_is_fitted_on_the_rayleigh_curve():
    # A lift with the Rayleigh colour of an air mass comes back as it is ...
    np.testing.assert_allclose(_fit_tint(sun_tint(4.4)), sun_tint(4.4), atol=1e-5)
    # ... a bluish lift (the veil, a clipped core) is pulled onto the curve: warm, never blue.
    t = _fit_tint(np.array([0.9, 0.95, 1.0]))
    np.testing.assert_allclose(t, sun_tint(1.0), atol=1e-6)
    assert t[0] == 1.0 and t[0] > t[1] > t[2]


def test_a_grey_step_is_not_a_sun_lobe():
    # a grey band with sharp edges (lane paint, a concrete verge) as bright as the lobe
    y = _clean_signal()
    y[90:, 150:170] += 0.8
    u8 = (_display(y) * 255 + 0.5).astype(np.uint8)
    out, mask = remove_glare(u8)
    assert not mask.any()
    np.testing.assert_array_equal(out, u8)


@pytest.mark.parametrize("noise", ["clear", "rain", "snow", "shadow"])
def test_rendered_frames_without_glare_pass_through_bit_identical(noise):
    frames = collect_frames(scenarios=("highway", "town"), seeds=[7], frames_per_seed=2, every=6, noise=noise)
    for img in frames.images:
        out, mask = remove_glare(img)
        assert not mask.any()
        np.testing.assert_array_equal(out, img)


def test_a_rendered_low_sun_ahead_is_found_and_removed(shared_frames):
    frames = shared_frames(scenarios=("highway",), seeds=[7], frames_per_seed=1, noise="glare", severity=0.8)
    img = frames.images[0]
    out, mask = remove_glare(img)
    assert mask[100:].mean() > 0.02 and not mask[:70].any()
    assert out[mask].mean() < img[mask].mean()  # the lobe is gone


def test_a_rendered_low_sun_on_pale_aged_asphalt_is_found():
    # World 210 (a validation world) has pale aged asphalt (albedo ~0.19, twice a typical
    # road's): the sun's specular lobe is the same, the diffuse floor under it twice as
    # bright, so the lobe lifts the floor by half as much (1.9-2.5x its level here).
    frames = collect_frames(
        scenarios=("highway",), seeds=[210], frames_per_seed=3, every=6, noise="glare", severity=0.4
    )
    for img in frames.images:
        out, mask = remove_glare(img)
        assert mask[100:].mean() > 0.02 and not mask[:70].any()
        assert out[mask].mean() < img[mask].mean()  # the lobe is gone


@pytest.mark.parametrize(
    ("scenario", "seed", "step", "noise"),
    [
        ("highway", 201, 12, "clear"),  # a lit concrete verge beside dark asphalt: warm, a bell, but slanted
        ("winding", 246, 30, "clear"),  # the same on a bend
        ("highway", 234, 6, "snow"),  # a white car ahead with its tail lights on a snowy road
    ],
)
def test_a_lit_verge_or_a_car_is_not_a_sun_lobe(scenario, seed, step, noise):
    # Rendered frames (validation worlds) that pass the lobe's brightness, concentration and
    # symmetry tests: a verge's lift converges to the vanishing point (the sun's
    # reflections lie on a vertical line), a car's red lights are not as warm as a low sun.
    frames = collect_frames(
        scenarios=(scenario,), seeds=[seed], frames_per_seed=step // 6 + 1, every=6, noise=noise, severity=0.8
    )
    img = frames.images[-1]
    out, mask = remove_glare(img)
    assert not mask.any()
    np.testing.assert_array_equal(out, img)


def _with_sidewalks(y: np.ndarray) -> np.ndarray:
    """Pale grey sidewalks (40 px, narrower than the ``wide`` opening) either side of the asphalt."""
    y = y.copy()
    y[90:, 75:115] += 0.2
    y[90:, 205:245] += 0.2
    return y


def test_a_lobe_between_pale_sidewalks_is_found():
    # A town street: the sidewalks lift over the floor as well and take a third of the
    # lift's column profile from the lobe (0.38 of it stays within +-3/80 of the
    # width of the peak); the lobe is still a warm bell on one column in every lit row.
    lit, _ = _glare_signal(peak=2.5)
    out, mask = remove_glare(_display(_with_sidewalks(lit)))
    assert mask[120:, 160].all() and not mask[:, :20].any()
    # the sidewalks alone are grey steps, not a sun's lobe
    u8 = (_display(_with_sidewalks(_clean_signal())) * 255 + 0.5).astype(np.uint8)
    out, mask = remove_glare(u8)
    assert not mask.any()
    np.testing.assert_array_equal(out, u8)


def test_the_lobe_is_found_at_every_frame_size():
    # The same scene at 320x180 and 1280x720: the filter looks for the lobe on the same
    # reduced image (its ``wide`` opening is a third of the width at every size).
    lit, _ = _glare_signal(peak=2.5)
    small = _display(lit)
    big = _display(cv2.resize(lit, (4 * W, 4 * H), interpolation=cv2.INTER_LINEAR))
    m_small, m_big = remove_glare(small).mask, remove_glare(big).mask
    assert m_small.any() and m_big.any()
    shrunk = cv2.resize(m_big.view(np.uint8), (W, H), interpolation=cv2.INTER_AREA) > 0
    assert (shrunk != m_small).mean() < 0.02
