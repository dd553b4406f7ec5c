"""RoadDetector: sklearn conventions, persistence without pickle, clean-frame accuracy."""

from __future__ import annotations

import copy
import inspect
import json

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from simroad import SimroadError
from simroad.detector import GlareMemory, RoadDetector, default_model_path, postprocess, train_default
from simroad.envs import SCENARIO_NAMES
from simroad.filters.pipeline import FILTERS
from simroad.metrics import MaskScore


def test_predict_returns_a_bool_mask_equal_to_the_exact_svm(small_detector, heldout_frames):
    img = heldout_frames[0][0]
    fast = small_detector.predict(img)
    assert fast.dtype == bool and fast.shape == img.shape[:2]
    np.testing.assert_array_equal(fast, small_detector.predict(img, exact=True))
    for dtype in ("float32", "float64"):
        as_float = (img / 255).astype(dtype)
        assert (small_detector.predict(as_float) == fast).mean() > 0.999


@pytest.mark.parametrize("filters", [(), ("shadow",), ("rain_snow",), ("light",), FILTERS])
def test_every_filter_subset_runs_and_morphology_switches(small_detector, heldout_frames, filters):
    img = heldout_frames[0][1]
    det = copy.deepcopy(small_detector).set_params(filters=filters)
    with_m = det.predict(img)
    without = det.set_params(morphology=False).predict(img)
    assert with_m.shape == without.shape == img.shape[:2]
    # A clean frame (no veil, no sun's lobe): the switch adds exactly §III's morphology,
    # and on this frame that changes the mask.
    np.testing.assert_array_equal(with_m, postprocess(without))
    assert not np.array_equal(with_m, without)


def test_init_only_stores_and_clone_round_trips():
    det = RoadDetector(filters=("shadow", "light"), morphology=False, C=3.0, max_samples=99, lut_bits=5, random_state=4)
    assert det.get_params() == {"filters": ("shadow", "light"), "morphology": False, "C": 3.0, "gamma": "scale",
                                "max_samples": 99, "nonroad_weight": 1.0, "lut_bits": 5,
                                "random_state": 4, "filter_variant": "improved", "normalize": "none"}  # fmt: skip
    assert not [k for k in vars(det) if k.endswith("_")]
    assert clone(det).get_params() == det.get_params()
    RoadDetector(filters="nonsense")  # validated in fit/predict, not in __init__


def test_options_are_keyword_only():
    for fn in (RoadDetector, RoadDetector.pretrained):
        params = inspect.signature(fn).parameters.values()
        assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params), fn
    with pytest.raises(TypeError):
        RoadDetector(("shadow",))  # type: ignore[misc]
    with pytest.raises(TypeError):
        RoadDetector.pretrained(("shadow",))  # type: ignore[misc]


def test_predict_before_fit_is_not_fitted_error():
    with pytest.raises(NotFittedError, match="RoadDetector is not fitted yet"):
        RoadDetector().predict(np.zeros((20, 20, 3), np.uint8))
    with pytest.raises(NotFittedError):
        RoadDetector().save("never.npz")


def test_fit_is_deterministic(train_frames):
    a = RoadDetector(max_samples=600, random_state=3).fit(*train_frames)
    b = RoadDetector(max_samples=600, random_state=3).fit(*train_frames)
    np.testing.assert_array_equal(a.lut_.coarse, b.lut_.coarse)
    np.testing.assert_array_equal(a.lut_.fine, b.lut_.fine)
    np.testing.assert_array_equal(a.svm_.support_vectors, b.svm_.support_vectors)


def test_save_load_round_trip_without_pickle(small_detector, heldout_frames, tmp_path):
    path = tmp_path / "model.npz"
    small_detector.save(path)
    with np.load(path, allow_pickle=False) as data:  # arrays and a JSON string only
        meta = json.loads(str(data["meta"]))
        assert all(data[k].dtype != object for k in data.files)
    assert meta["format"] == "simroad.RoadDetector" and meta["params"]["lut_bits"] == 6
    loaded = RoadDetector.load(path)
    assert loaded.svc_ is None and loaded.get_params()["filters"] == ()  # a tuple, as given
    img = heldout_frames[0][2]
    np.testing.assert_array_equal(loaded.predict(img), small_detector.predict(img))
    np.testing.assert_array_equal(loaded.predict(img, exact=True), small_detector.predict(img, exact=True))


def test_load_refuses_pickles_and_garbage(tmp_path):
    pickled = tmp_path / "evil.npz"
    np.savez(pickled, meta=np.array([{"x": 1}], dtype=object))
    with pytest.raises(SimroadError, match="not a simroad road-detector"):
        RoadDetector.load(pickled)
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(SimroadError, match="not a simroad road-detector"):
        RoadDetector.load(tmp_path / "text.npz")
    with pytest.raises(SimroadError, match="no model file"):
        RoadDetector.load(tmp_path / "missing.npz")
    partial = tmp_path / "partial.npz"
    np.savez(partial, lut=np.zeros(3, np.uint8))
    with pytest.raises(SimroadError, match="missing"):
        RoadDetector.load(partial)


BAD_IMAGES = [
    (np.zeros((0, 0, 3), np.uint8), "at least 8x8"),
    (np.zeros((4, 30, 3), np.uint8), "at least 8x8"),
    (np.full((20, 20, 3), np.nan, np.float32), "NaN"),
    (np.zeros((20, 20, 3), np.int16), "dtype"),
    (np.zeros((20, 20), np.uint8), "shape"),
]


@pytest.mark.parametrize("bad,match", BAD_IMAGES)
def test_predict_rejects_bad_images(small_detector, bad, match):
    with pytest.raises(SimroadError, match=match):
        small_detector.predict(bad)


def test_constant_images_do_not_crash(small_detector):
    det = copy.deepcopy(small_detector).set_params(filters=FILTERS)
    for value in (0, 128, 255):
        assert det.predict(np.full((30, 40, 3), value, np.uint8)).shape == (30, 40)


def test_fit_rejects_bad_training_sets(train_frames):
    imgs, masks = train_frames
    det = RoadDetector(max_samples=200)
    with pytest.raises(SimroadError, match=r"masks\[0\]: expected shape"):
        det.fit(imgs[:1], [masks[0][:-1]])
    with pytest.raises(SimroadError, match="one mask per image"):
        det.fit(imgs[:2], masks[:1])
    with pytest.raises(SimroadError, match="at least one training image"):
        det.fit([], [])
    with pytest.raises(SimroadError, match="every training pixel is road"):
        det.fit(imgs[:1], [np.ones_like(masks[0])])
    with pytest.raises(SimroadError, match="Wrap a single image"):
        det.fit(imgs[0], masks[0])
    with pytest.raises(SimroadError, match="filters: unknown value 'rain'"):
        RoadDetector(filters=("rain",)).fit(imgs, masks)
    with pytest.raises(SimroadError, match="C: expected a value"):
        RoadDetector(C=-1).fit(imgs, masks)
    for bad in (0, -2.0, float("nan"), "heavy"):
        with pytest.raises(SimroadError, match="nonroad_weight"):
            RoadDetector(nonroad_weight=bad).fit(imgs, masks)


@pytest.mark.slow
def test_nonroad_weight_trades_false_road_for_missed_road(train_frames, heldout_frames):
    """A higher cost on non-road training pixels must call fewer pixels road: lower
    FPR, higher FNR, on frames the model has not seen (exact SVM, no morphology)."""
    rates = []
    for weight in (1.0, 4.0):
        det = RoadDetector(morphology=False, max_samples=1500, nonroad_weight=weight).fit(*train_frames)
        score = MaskScore()
        for img, gt in zip(*heldout_frames):
            score.update(det.predict(img, exact=True), gt)
        rates.append(score.pooled())
    assert rates[1]["fpr"] < rates[0]["fpr"] and rates[1]["fnr"] > rates[0]["fnr"], rates


@pytest.mark.slow
def test_train_default_is_reproducible(train_frames):
    imgs, masks = train_frames[0][:2], train_frames[1][:2]
    a = train_default(imgs, masks, rng=np.random.default_rng(5))
    b = train_default(imgs, masks, rng=5)
    np.testing.assert_array_equal(a.lut_.fine, b.lut_.fine)
    assert a.filters == () and a.morphology


@pytest.mark.slow
def test_pretrained_model_meets_clean_frame_targets_in_every_scenario():
    """Clean frames of held-out worlds (100-104, never trained on), every scenario,
    pooled, each frame on its own (no camera ground). The world has grey sidewalks,
    kerbs, gravel and concrete verges, and a camera that exposes and balances for the
    whole scene, as real roads and cameras do: the shipped model measures FNR 7.6 %,
    FPR 15.7 % here (pale verges and sidewalks the colour of the road); the bounds
    guard that with some room."""
    from simroad.experiments.frames import collect_frames

    frames = collect_frames(seeds=range(100, 105), frames_per_seed=4, every=16)
    det = RoadDetector.pretrained()
    score = MaskScore()
    for img, gt, valid in zip(frames.images, frames.masks, frames.valid):
        score.update(det.predict(img), gt, valid=valid)
    pooled = score.pooled()
    assert score.n_frames == 4 * 5 * len(SCENARIO_NAMES)
    assert pooled["fnr"] <= 0.09 and pooled["fpr"] <= 0.18, pooled


def test_pretrained_model_is_small_and_meets_clean_frame_targets(heldout_frames):
    assert default_model_path().stat().st_size < 1_000_000
    det = RoadDetector.pretrained()
    score = MaskScore()
    for img, gt in zip(*heldout_frames):
        score.update(det.predict(img), gt)
    pooled = score.pooled()
    # The 15 frames of the fixture's held-out worlds: FNR 3.5 %, FPR 6.3 % measured
    # with the model retrained on the issue-14 world (simroad 0.1: both <= 3 %).
    assert pooled["fnr"] <= 0.05 and pooled["fpr"] <= 0.08, pooled
    assert RoadDetector.pretrained(filters=["light", "shadow"]).filters == ("light", "shadow")


def test_constructor_defaults_are_the_documented_ones():
    from simroad.detector.detector import DEFAULT_MAX_SAMPLES

    sig = inspect.signature(RoadDetector)
    assert sig.parameters["max_samples"].default == DEFAULT_MAX_SAMPLES == 16000
    assert RoadDetector().max_samples == DEFAULT_MAX_SAMPLES
    assert "DEFAULT_MAX_SAMPLES" in RoadDetector.__doc__
    assert sig.parameters["nonroad_weight"].default == 1.0  # not the shipped model's (SHIPPED_NONROAD_WEIGHT)
    assert "SHIPPED_NONROAD_WEIGHT" in RoadDetector.__doc__


def test_filters_stay_a_tuple_after_save_and_load(small_detector, tmp_path):
    det = copy.deepcopy(small_detector).set_params(filters=("light", "shadow"))
    det.save(tmp_path / "m.npz")
    loaded = RoadDetector.load(tmp_path / "m.npz")
    assert loaded.filters == ("light", "shadow") and isinstance(loaded.filters, tuple)
    assert loaded.get_params() == det.get_params()


def test_the_shipped_model_loads_with_its_stored_parameters():
    from simroad.detector.training import SHIPPED_MAX_SAMPLES, SHIPPED_NONROAD_WEIGHT

    det = RoadDetector.load(default_model_path())
    assert det.filters == () and isinstance(det.filters, tuple)
    assert det.max_samples == 16000 and det.nonroad_weight == 2.0
    assert (det.max_samples, det.nonroad_weight) == (SHIPPED_MAX_SAMPLES, SHIPPED_NONROAD_WEIGHT)


def test_a_known_camera_keeps_the_mask_below_its_horizon(small_detector, heldout_frames):
    from simroad.camera import CameraConfig, PinholeCamera

    image = heldout_frames[0][0].copy()
    h, w = image.shape[:2]
    camera = PinholeCamera(CameraConfig(width=w, height=h))
    det = copy.deepcopy(small_detector).set_params(filters=())
    # a road-coloured column from the bottom centre up through the horizon to the top, in
    # the colour of the bottom row's centre-most pixel the classifier calls road, wider
    # than a lane marking (a thin line is kept apart from the road's component)
    bottom = det.set_params(morphology=False).predict(image)[h - 1]
    det.set_params(morphology=True)
    x = int(np.flatnonzero(bottom)[np.argmin(np.abs(np.flatnonzero(bottom) - w // 2))])
    road = image[h - 1, x].copy()
    image[:, w // 2 - 8 : w // 2 + 8] = road
    free = det.predict(image)
    assert free[: h // 4, w // 2].any()  # the column joins the road component above the horizon
    episode = det.episode(camera)
    clipped = episode.predict(image)
    assert not clipped[~camera.ground_valid].any()
    assert np.array_equal(clipped[camera.ground_valid], free[camera.ground_valid])
    # the paper's variant knows no camera; an episode without one gives the detector's own mask
    det.set_params(filter_variant="paper")
    assert np.array_equal(episode.predict(image), det.predict(image))
    det.set_params(filter_variant="improved")
    assert np.array_equal(det.episode(None).predict(image), free)
    assert np.array_equal(det.predict_step(image, GlareMemory(), ground=camera.ground_valid)[0], clipped)
    with pytest.raises(SimroadError, match="camera: expected a calibrated camera"):
        det.episode("front")
