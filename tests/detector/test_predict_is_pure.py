"""``predict`` does not change the estimator (scikit-learn's ``check_dict_unchanged``,
with a deep copy and arrays compared): over a frame sequence with glare frames where the
light filter removes a lobe, with and without a camera. What persists across an
episode's frames lives in the episode the caller owns."""

from __future__ import annotations

import copy
import dataclasses

import joblib
import numpy as np
import pytest

from simroad import SimroadError
from simroad.detector import DetectorEpisode, GlareMemory, RoadDetector
from simroad.detector.episode import GLARE_MEMORY_FRAMES
from simroad.filters import FILTERS, remove_glare


def same(a, b, where="__dict__"):
    """Deep equality: arrays by dtype, shape and values; objects by type and attributes."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), f"{where}: keys {sorted(a)} != {sorted(b)}"
        for key in a:
            same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif hasattr(a, "__dict__") and not isinstance(a, type):
        same(vars(a), vars(b), f"{where}.{type(a).__name__}")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


@pytest.fixture(scope="module")
def frames(shared_frames):
    glare = shared_frames(scenarios=("highway",), seeds=[7], frames_per_seed=1, noise="glare", severity=0.8)
    clear = shared_frames(scenarios=("town",), seeds=[7], frames_per_seed=1)
    sun = shared_frames(scenarios=("winding",), seeds=[0], frames_per_seed=1, noise="glare", severity=0.7, every=8)
    return glare.images[0], clear.images[0], sun.images[0], sun.valid[0]


@pytest.mark.parametrize("filter_variant", ["improved", "paper"])
def test_predict_leaves_the_detector_unchanged(frames, filter_variant):
    glare, clear, sun, ground = frames
    assert remove_glare(glare).mask.any() and remove_glare(sun).mask.any()  # the light filter removes lobes

    class Camera:
        ground_valid = ground

    det = RoadDetector.pretrained(filters=FILTERS, filter_variant=filter_variant)
    before, digest = copy.deepcopy(det.__dict__), joblib.hash(det.__dict__)
    alone = [det.predict(f) for f in (clear, glare, clear, sun, clear)]
    episode = det.episode(Camera())
    seq = [episode.predict(f) for f in (clear, glare, clear, sun, clear)]
    step = det.predict_step(clear, GlareMemory(0, 0.5), ground=ground)
    det.predict(clear[:90, :160], exact=True)
    same(before, det.__dict__)
    assert joblib.hash(det.__dict__) == digest
    # predict is a function of the frame alone
    for f, mask in zip((clear, glare, clear, sun, clear), alone):
        np.testing.assert_array_equal(det.predict(f), mask)
    if filter_variant == "improved":  # the episode did remember: the lobe, then the camera's ground
        assert episode.memory == GlareMemory(1, 0.0)
        assert not (seq[3] & ~ground).any()
        assert step[1] == GlareMemory(1, 0.5)
    else:
        assert episode.memory == GlareMemory() and step[1] == GlareMemory(0, 0.5)


def test_the_mask_driver_leaves_the_detector_unchanged(frames):
    from simroad.control import make_driver
    from simroad.envs import RoadCamEnv

    det = RoadDetector.pretrained(filters=FILTERS)
    before = copy.deepcopy(det.__dict__)
    env = RoadCamEnv(scenario="highway", noise="glare", severity=0.8, longitudinal=True, width=160, height=90)
    driver = make_driver("detector", env, detector=det)
    obs, info = env.reset(seed=7)
    driver.reset()
    assert isinstance(driver.episode, DetectorEpisode) and driver.episode.detector is det
    np.testing.assert_array_equal(driver.episode.ground, env.camera.ground_valid)
    for _ in range(3):
        obs, *_, info = env.step(driver(obs, info))
    assert driver.episode.memory.since_lobe is not None  # a lobe was seen and remembered, by the episode
    env.close()
    same(before, det.__dict__)


def test_two_episodes_of_one_detector_run_side_by_side(frames):
    glare, clear, _, _ = frames
    det = RoadDetector.pretrained(filters=FILTERS)
    a, b = det.episode(), det.episode()
    a.predict(glare)
    fresh = b.predict(clear)
    remembered = a.predict(clear)
    assert (remembered != fresh).any()
    np.testing.assert_array_equal(det.predict(clear), fresh)
    assert a.name == "RoadDetector" and a.version == ""


def test_glare_memory_is_a_checked_value():
    memory = GlareMemory()
    assert not memory.active and memory.next_frame() == memory
    lobe = np.zeros((10, 4), bool)
    lobe[6:, 1] = True
    seen = memory.saw_lobe(lobe, keep_top=False)
    assert seen == GlareMemory(0, 0.6) and seen.active
    assert memory.saw_lobe(lobe, keep_top=True) == GlareMemory(0, 0.0)
    later = seen
    for _ in range(GLARE_MEMORY_FRAMES):
        later = later.next_frame()
    assert later.active and not later.next_frame().active
    np.testing.assert_array_equal(seen.growth_bound(None, (10, 4)), np.arange(10)[:, None].repeat(4, 1) >= 6)
    with pytest.raises(dataclasses.FrozenInstanceError):
        seen.since_lobe = 3  # type: ignore[misc]
    for bad in ({"since_lobe": -1}, {"since_lobe": 1.5}, {"since_lobe": True}, {"lobe_top": 2.0}, {"lobe_top": "0"}):
        with pytest.raises(SimroadError, match=next(iter(bad))):
            GlareMemory(**bad)


def test_predict_step_refuses_what_is_not_a_memory_or_a_ground(frames):
    clear = frames[1]
    det = RoadDetector.pretrained()
    with pytest.raises(SimroadError, match="memory: expected a GlareMemory"):
        det.predict_step(clear, None)  # type: ignore[arg-type]
    with pytest.raises(SimroadError, match="ground: expected None or a bool"):
        det.predict_step(clear, GlareMemory(), ground=np.ones(clear.shape[:2], np.uint8))
    with pytest.raises(SimroadError, match="detector: expected a RoadDetector"):
        DetectorEpisode(object())  # type: ignore[arg-type]
