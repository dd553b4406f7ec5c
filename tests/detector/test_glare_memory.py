"""The improved detector's memory of a sun's lobe (RoadDetector.episode, GlareMemory, GLARE_MEMORY_FRAMES)."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.detector import RoadDetector
from simroad.detector.episode import GLARE_MEMORY_FRAMES, GlareMemory
from simroad.detector.registry import predict_alone
from simroad.filters import FILTERS, remove_glare


@pytest.fixture(scope="module")
def frames(shared_frames):
    glare = shared_frames(scenarios=("highway",), seeds=[7], frames_per_seed=1, noise="glare", severity=0.8)
    clear = shared_frames(scenarios=("town",), seeds=[7], frames_per_seed=1)
    return glare.images[0], clear.images[0]


def test_a_lobe_is_remembered_for_glare_memory_frames(frames):
    glare, clear = frames
    assert remove_glare(glare).mask.any()  # the light filter removes a lobe here
    assert not remove_glare(clear).mask.any()  # and none here
    det = RoadDetector.pretrained(filters=FILTERS)
    fresh = det.predict(clear)
    episode = det.episode()
    episode.predict(glare)
    assert episode.memory == GlareMemory(0, episode.memory.lobe_top)
    after = [episode.predict(clear) for _ in range(GLARE_MEMORY_FRAMES + 1)]
    # within the memory the road is grown from under the ego (it stops at the town's
    # centre line), not read from the colour classifier ...
    assert (after[0] != fresh).any()
    assert all(np.array_equal(a, after[0]) for a in after[1:-1])
    # ... and after it the frame is read as on its own
    np.testing.assert_array_equal(after[-1], fresh)


def test_reset_and_predict_alone_forget_the_lobe(frames):
    glare, clear = frames
    det = RoadDetector.pretrained(filters=FILTERS)
    episode = det.episode()
    fresh = episode.predict(clear)
    np.testing.assert_array_equal(det.predict(clear), fresh)  # predict: an episode's first frame
    episode.predict(glare)
    np.testing.assert_array_equal(predict_alone(episode, clear), fresh)
    np.testing.assert_array_equal(predict_alone(det, clear), fresh)
    episode.predict(glare)
    np.testing.assert_array_equal(episode.reset().predict(clear), fresh)
    episode.predict(glare)
    np.testing.assert_array_equal(det.predict(clear), fresh)  # the detector itself remembers nothing


@pytest.mark.parametrize(
    "kwargs", [{"filters": ("shadow", "rain_snow")}, {"filters": FILTERS, "filter_variant": "paper"}]
)
def test_without_the_improved_light_filter_nothing_is_remembered(frames, kwargs):
    glare, clear = frames
    episode = RoadDetector.pretrained(**kwargs).episode()
    fresh = episode.predict(clear)
    episode.predict(glare)
    np.testing.assert_array_equal(episode.predict(clear), fresh)
    assert episode.memory == GlareMemory()


@pytest.fixture(scope="module")
def sun_down_the_lane(shared_frames):
    """A winding-road frame whose glare lobe runs up towards the horizon and the bright sky:
    without a bound, growth from the lobe would climb into the sky."""
    fs = shared_frames(scenarios=("winding",), seeds=[3], frames_per_seed=1, noise="glare", severity=0.7, every=8)
    return fs.images[0], fs.valid[0]


def test_without_a_camera_growth_stays_below_the_lobes_top(sun_down_the_lane, frames):
    image, ground = sun_down_the_lane
    clear = frames[1]
    det = RoadDetector.pretrained(filters=FILTERS)  # no camera: a frame or photograph on its own
    lobe = remove_glare(image).mask
    assert lobe.any()
    top = int(np.argmax(lobe.any(axis=1)))
    mask = det.predict(image)
    assert mask.any()
    assert not mask[:top].any()
    assert not (mask & ~ground).any()  # the sky never joins the road
    # on the frames the memory covers, the bound is the last lobe's top (the town's
    # road reaches higher on its own)
    assert det.predict(clear)[:top].any()
    episode = det.episode()
    episode.predict(image)
    assert episode.memory.lobe_top == top / image.shape[0]
    within = episode.predict(clear)
    assert within.any() and not within[:top].any()


def test_with_a_camera_growth_is_bounded_by_its_ground(sun_down_the_lane):
    image, ground = sun_down_the_lane

    class Camera:
        ground_valid = ground

    episode = RoadDetector.pretrained(filters=FILTERS).episode(Camera())
    mask = episode.predict(image)
    assert mask.any() and not (mask & ~ground).any()
    assert mask[: int(np.argmax(remove_glare(image).mask.any(axis=1)))].any()  # up to the horizon, above the lobe
