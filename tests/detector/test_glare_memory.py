"""The improved detector's memory of a sun's lobe (RoadDetector.reset, GLARE_MEMORY_FRAMES)."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.detector import RoadDetector
from simroad.detector.detector import GLARE_MEMORY_FRAMES
from simroad.detector.registry import predict_alone
from simroad.experiments.frames import collect_frames
from simroad.filters import FILTERS, remove_glare


@pytest.fixture(scope="module")
def frames():
    glare = collect_frames(scenarios=("highway",), seeds=[7], frames_per_seed=1, noise="glare", severity=0.8)
    clear = collect_frames(scenarios=("town",), seeds=[7], frames_per_seed=1)
    return glare.images[0], clear.images[0]


def test_a_lobe_is_remembered_for_glare_memory_frames(frames):
    glare, clear = frames
    assert remove_glare(glare).mask.any()  # the light filter removes a lobe here
    assert not remove_glare(clear).mask.any()  # and none here
    det = RoadDetector.pretrained(filters=FILTERS)
    fresh = det.reset().predict(clear)
    det.predict(glare)
    after = [det.predict(clear) for _ in range(GLARE_MEMORY_FRAMES + 1)]
    # within the memory the road is grown from under the ego (it stops at the town's
    # centre line), not read from the colour classifier ...
    assert (after[0] != fresh).any()
    assert all(np.array_equal(a, after[0]) for a in after[1:-1])
    # ... and after it the frame is read as on its own
    np.testing.assert_array_equal(after[-1], fresh)


def test_reset_and_predict_alone_forget_the_lobe(frames):
    glare, clear = frames
    det = RoadDetector.pretrained(filters=FILTERS)
    fresh = det.reset().predict(clear)
    det.predict(glare)
    np.testing.assert_array_equal(predict_alone(det, clear), fresh)
    det.predict(glare)
    np.testing.assert_array_equal(det.reset().predict(clear), fresh)


@pytest.mark.parametrize(
    "kwargs", [{"filters": ("shadow", "rain_snow")}, {"filters": FILTERS, "filter_variant": "paper"}]
)
def test_without_the_improved_light_filter_nothing_is_remembered(frames, kwargs):
    glare, clear = frames
    det = RoadDetector.pretrained(**kwargs)
    fresh = det.reset().predict(clear)
    det.predict(glare)
    np.testing.assert_array_equal(det.predict(clear), fresh)
