"""The runner's sparse encoding (pixels a stage touched) against linear_to_srgb and change_mask."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.core.radiometry import change_mask, linear_to_srgb, srgb_to_linear
from simroad.noise import NoiseContext, WindscreenParams, make_weather
from simroad.noise._encode_kernel import encode_tables, encode_touched


def _reference(values: np.ndarray) -> np.ndarray:
    pad = (-values.size) % 3
    x = np.concatenate([values.astype(np.float32), np.zeros(pad, np.float32)]).reshape(-1, 1, 3)
    return linear_to_srgb(x).ravel()[: values.size]


def _sparse(values: np.ndarray) -> np.ndarray:
    pad = (-values.size) % 3
    x = np.concatenate([values.astype(np.float32), np.zeros(pad, np.float32)]).reshape(-1, 1, 3)
    previous = np.zeros(x.shape, np.uint8)
    enc, _ = encode_touched(x, np.ones(x.shape[:2], bool), previous, 8)
    return enc.ravel()[: values.size]


def test_every_level_step_and_its_neighbours_encode_as_linear_to_srgb():
    _, step = encode_tables()
    edges = step[step < (np.arange(len(step)) + 1) << 16]  # the buckets where the level steps up
    assert 200 < len(edges) <= 255  # one step per level above the darkest
    bits = (edges[:, None] + np.arange(-3, 4)).ravel()
    values = bits.astype(np.uint32).view(np.float32)
    np.testing.assert_array_equal(_sparse(values), _reference(values))


def test_random_values_negatives_and_saturation_encode_as_linear_to_srgb(rng):
    values = np.concatenate(
        [
            rng.random(300_000, dtype=np.float32),  # the working range
            rng.random(30_000, dtype=np.float32) ** 8,  # the darkest levels
            rng.uniform(0.9, 4.0, 30_000).astype(np.float32),  # around and past saturation
            np.float32(
                [-1.0, -0.0, 0.0, 1e-30, 1e-7, 1.0, 2.0, 1e6, 1e12]
            ),  # (above ~1e15 linear_to_srgb overflows to 0)
        ]
    )
    np.testing.assert_array_equal(_sparse(values), _reference(values))


def test_untouched_pixels_keep_the_previous_encoding_and_the_mask_matches(rng):
    lin = rng.random((40, 50, 3), dtype=np.float32)
    previous = linear_to_srgb(lin)
    touched = np.zeros((40, 50), bool)
    touched[5:12, 7:30] = True
    touched[33, 49] = True
    lin[touched] *= np.float32(1.5)
    lin[0, 0] = 9.0  # untouched: must not be encoded
    enc, changed = encode_touched(lin, touched, previous, 8)
    expected = linear_to_srgb(lin)
    np.testing.assert_array_equal(enc[touched], expected[touched])
    np.testing.assert_array_equal(enc[~touched], previous[~touched])
    np.testing.assert_array_equal(changed, change_mask(previous, enc))
    assert changed[touched].any() and not changed[~touched].any()


@pytest.mark.parametrize("noise", ["rain", "snow+shadow"])
def test_the_windscreen_stage_gives_the_frames_and_masks_of_a_full_encode(noise, monkeypatch):
    """The runner encodes only the drops' pixels after the windscreen; forcing the full
    encode gives the same bits."""
    import simroad.noise.model as model
    from simroad.experiments.scene import SCENE_EGO_SPEED_M_S, sample_scene

    frame, cam, world = sample_scene(seed=0)
    kw = dict(camera=cam, depth=frame.depth, material=frame.material, vehicles=frame.vehicles)

    def run() -> list:
        weather = make_weather(noise, severity=0.9, windscreen=WindscreenParams(wiper_period_s=1.0))
        weather.reset(np.random.default_rng(4), world=world)
        return [
            weather.apply(frame.rgb, NoiseContext(time_s=k / 15, dt=1 / 15, ego_speed=SCENE_EGO_SPEED_M_S, **kw))
            for k in range(1, 25)
        ]

    sparse = run()
    calls = []
    real = model.encode_touched
    monkeypatch.setattr(model, "encode_touched", lambda *a: calls.append(1) or real(*a))
    run()
    assert len(calls) == 24  # the sparse path runs once per frame
    monkeypatch.setattr(
        model, "encode_touched", lambda lin, *a: (linear_to_srgb(lin), change_mask(a[1], linear_to_srgb(lin), a[2]))
    )
    full = run()
    for (a, ma), (b, mb) in zip(sparse, full, strict=True):
        np.testing.assert_array_equal(a, b)
        assert ma.keys() == mb.keys() and all(np.array_equal(ma[k], mb[k]) for k in ma)


def test_a_model_with_two_stages_is_encoded_whole_even_if_its_last_stage_says_touched(rng):
    """``touched`` speaks for one stage: a model whose earlier stage changed other
    pixels gets the full encode (its mask and the frame keep both changes)."""
    from dataclasses import dataclass

    from simroad.noise.model import NoiseModel, Params, run_models

    @dataclass(frozen=True)
    class _On(Params):
        @classmethod
        def from_severity(cls, severity: float) -> _On:
            return cls()

        @property
        def is_identity(self) -> bool:
            return False

    class _First(NoiseModel):  # one stage, before the other: the frame is encoded after it
        name, params_type, stages = "first", _On, ("material",)

        def material(self, state) -> None:
            state.lin[150:, :] *= np.float32(0.9)

    class _TwoStages(NoiseModel):
        name, params_type, stages = "two", _On, ("atmosphere", "windscreen")

        def atmosphere(self, state) -> None:
            state.lin[:60] *= np.float32(0.3)  # the sky rows, darker

        def windscreen(self, state) -> None:
            state.lin[100:110, 100:110] = 1.0
            touched = np.zeros(state.shape, bool)
            touched[100:110, 100:110] = True
            state.touched = touched  # true of this stage only

    image = rng.integers(40, 220, (180, 320, 3)).astype(np.uint8)
    models = [_First(_On()), _TwoStages(_On())]
    for m in models:
        m.reset(0)
    out, masks = run_models(models, image)
    lin = srgb_to_linear(image)
    lin[150:] *= np.float32(0.9)
    lin[:60] *= np.float32(0.3)
    lin[100:110, 100:110] = 1.0
    np.testing.assert_array_equal(out, linear_to_srgb(lin))
    assert masks["two"][:60].mean() > 0.9 and masks["two"][100:110, 100:110].all()
