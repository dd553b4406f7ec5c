"""Fitting a camera profile: the search space, the objective, refusals before any
rendering, and the recovery of a known profile from frames simroad rendered with it."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from simroad.camera.profile import PROFILE_RANGES, CameraProfile, load_profile
from simroad.errors import InvalidParameterError
from simroad.experiments import calibrate as calibrate_module
from simroad.experiments.calibrate import (
    OBJECTIVE_LEVELS,
    UNIT_FLOOR,
    CalibrationObjective,
    calibrate_from_photos,
    calibrate_profile,
    calibration_objective,
    format_calibration,
    ks_distances,
    profile_statistics,
    write_calibration,
)
from simroad.experiments.profile_space import FIT_PARAMETERS, check_fit, from_unit, to_unit, unit_coordinates
from simroad.metrics.appearance import STATISTICS

TRUTH = CameraProfile(exposure_bias_ev=0.8, wb_preset_k=4200.0, tone_gamma=1.3, asphalt_scale=1.4)
FOUR = ("exposure_bias_ev", "wb_preset_k", "tone_gamma", "asphalt_scale")


def _values(shift: float = 0.0, n: int = 40) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {s: rng.normal(0.4, 0.1, n) + shift for s in STATISTICS}


# --- the search space ---------------------------------------------------------------


def test_unit_coordinates_round_trip_every_default_field():
    coords = unit_coordinates(FIT_PARAMETERS)
    assert len(coords) == len(FIT_PARAMETERS) + 1  # sky_brightness has two ends
    profile = CameraProfile(
        exposure_bias_ev=-0.7, exposure_spread_ev=0.3, wb_preset_k=4200.0, awb_strength=0.6, tone_gamma=1.3,
        asphalt_scale=1.4, sky_brightness=(0.9, 2.5), overcast_share=0.3, hazy_share=0.1,
    )  # fmt: skip
    x = to_unit(profile, coords)
    assert np.all((x >= 0.0) & (x <= 1.0))
    back = from_unit(x, CameraProfile(), coords)
    for name in FIT_PARAMETERS:
        assert np.allclose(getattr(back, name), getattr(profile, name), rtol=1e-4), name


def test_the_box_is_the_profile_ranges_and_the_white_balance_is_in_mired():
    coords = unit_coordinates(("wb_preset_k", "tone_gamma"))
    lo, hi = from_unit(np.zeros(2), CameraProfile(), coords), from_unit(np.ones(2), CameraProfile(), coords)
    assert lo.tone_gamma == PROFILE_RANGES["tone_gamma"][0] and hi.tone_gamma == PROFILE_RANGES["tone_gamma"][1]
    assert {lo.wb_preset_k, hi.wb_preset_k} == {PROFILE_RANGES["wb_preset_k"][0], PROFILE_RANGES["wb_preset_k"][1]}
    mid = from_unit(np.array([0.5, 0.5]), CameraProfile(), coords).wb_preset_k
    mireds = [1e6 / PROFILE_RANGES["wb_preset_k"][i] for i in (0, 1)]
    assert mid == pytest.approx(1e6 / np.mean(mireds), rel=1e-4)
    outside = from_unit(np.array([-3.0, 7.0]), CameraProfile(), coords)  # clipped into the box
    assert outside == from_unit(np.array([0.0, 1.0]), CameraProfile(), coords)


def test_shares_past_one_are_scaled_and_sky_ends_sorted():
    coords = unit_coordinates(("sky_brightness", "overcast_share", "hazy_share"))
    p = from_unit(np.array([0.9, 0.1, 0.8, 0.6]), CameraProfile(), coords)
    assert p.sky_brightness[0] < p.sky_brightness[1]
    assert p.overcast_share + p.hazy_share == pytest.approx(1.0)
    assert p.overcast_share / p.hazy_share == pytest.approx(0.8 / 0.6, rel=1e-3)


def test_unknown_fit_fields_are_refused_with_a_suggestion():
    with pytest.raises(InvalidParameterError, match="Did you mean 'tone_gamma'"):
        check_fit(("tone_gama",))
    with pytest.raises(InvalidParameterError, match="fit: duplicate"):
        check_fit(("tone_gamma", "tone_gamma"))
    with pytest.raises(InvalidParameterError, match="fit: expected a list"):
        check_fit("tone_gamma")


# --- the objective -------------------------------------------------------------------


def test_objective_is_zero_for_the_same_values_and_grows_with_a_shift():
    ref = _values()
    assert calibration_objective(ref, ref) == 0.0
    small, large = calibration_objective(_values(0.02), ref), calibration_objective(_values(0.1), ref)
    assert 0.0 < small < large
    # Every quantile's unit is known here: 20 000 photos pin every quantile down to far
    # less than the floor, UNIT_FLOOR of the spread (p90 - p10). road_V shifted by its
    # spread then costs 1 / UNIT_FLOOR at every level, over 8 statistics.
    ref = _values(n=20_000)
    spread = float(np.subtract(*np.quantile(ref["road_V"], [0.9, 0.1])))
    shifted = dict(ref, road_V=ref["road_V"] + spread)
    assert calibration_objective(shifted, ref) == pytest.approx(1.0 / UNIT_FLOOR / len(STATISTICS), rel=1e-6)


def test_objective_units_are_the_photos_quantile_standard_errors():
    # 40 photos from N(0.4, 0.1): the median's standard error is about
    # sqrt(0.5 * 0.5 / 40) / phi(0) * 0.1 = 0.0198 (the asymptotic formula), above the
    # floor (0.05 * 2.56 * 0.1 = 0.0128); the bootstrap's estimate of it is the unit.
    objective = CalibrationObjective(_values(n=40))
    median = OBJECTIVE_LEVELS.index(0.5)
    assert objective.units["road_V"][median] == pytest.approx(0.0198, rel=0.3)
    # A statistic whose top quantile the photos pin down loosely (a few clipped frames
    # among many without) has a larger unit there than in the middle.
    ref = _values(n=200)
    ref["saturated"] = np.r_[np.zeros(170), np.random.default_rng(1).uniform(0.0, 0.3, 30)]
    units = CalibrationObjective(ref).units["saturated"]
    assert units[-1] > 3 * units[median]


def test_objective_leaves_out_nans_and_penalises_a_statistic_without_values():
    ref = _values()
    with_nans = {s: np.r_[v, np.nan] for s, v in ref.items()}
    assert calibration_objective(with_nans, ref) == 0.0
    missing = dict(ref, road_spread=np.array([np.nan]))
    assert calibration_objective(missing, ref) == pytest.approx(10.0 / len(STATISTICS))
    with pytest.raises(InvalidParameterError, match="reference: no finite value of saturated"):
        CalibrationObjective(dict(ref, saturated=[np.nan]))
    with pytest.raises(InvalidParameterError, match="reference: no finite value of road_V"):
        calibration_objective(ref, dict(ref, road_V=[]))


def test_ks_distances_two_samples():
    ref = _values()
    assert ks_distances(ref, ref) == dict.fromkeys(STATISTICS, 0.0)
    assert all(d == 1.0 for d in ks_distances(_values(5.0), ref).values())


# --- the search, on a synthetic camera (no rendering) -------------------------------


def _synthetic(profile: CameraProfile, **_) -> dict[str, np.ndarray]:
    """Statistics that move smoothly with exposure, white balance, contrast and the asphalt."""
    base = np.linspace(-1.0, 1.0, 24)
    out = dict.fromkeys(STATISTICS, 0.3 + 0.05 * base)
    out["road_V"] = 0.35 + 0.08 * profile.exposure_bias_ev + 0.05 * base
    out["road_b"] = 0.004 * (profile.wb_preset_k - 4800.0) + 2.0 * base
    out["road_spread"] = 0.1 * profile.tone_gamma + 0.03 * base
    out["road_minus_surround"] = 0.1 * profile.asphalt_scale - 0.05 * profile.exposure_bias_ev + 0.02 * base
    return out


@pytest.fixture
def synthetic(monkeypatch):
    """A synthetic camera: a "render" records the profile's world fields, a "replay"
    scores the recorded world with the replayed profile's camera fields."""
    renders = []

    def record(profile, **_):
        renders.append(profile)
        return profile

    def replay(recorded, profile, **_):
        world = {f: getattr(recorded, f) for f in ("asphalt_scale", "sky_brightness", "overcast_share", "hazy_share")}
        return _synthetic(dataclasses.replace(profile, **world))

    monkeypatch.setattr(calibrate_module, "record_worlds", record)
    monkeypatch.setattr(calibrate_module, "replay_statistics", replay)
    return renders


def test_the_search_recovers_a_synthetic_camera_within_its_budget(synthetic):
    truth = CameraProfile(exposure_bias_ev=0.8, wb_preset_k=4200.0, tone_gamma=1.3)
    fit = ("exposure_bias_ev", "wb_preset_k", "tone_gamma")
    result = calibrate_profile(_synthetic(truth), fit=fit, max_replays=150)
    assert result.evaluations <= 150 and result.objective < 0.02 < result.start_objective
    assert result.renders == 1 == len(synthetic)  # camera fields only: one render, the rest replays
    assert result.profile.exposure_bias_ev == pytest.approx(0.8, abs=0.05)
    assert result.profile.wb_preset_k == pytest.approx(4200.0, abs=40.0)
    assert result.profile.tone_gamma == pytest.approx(1.3, abs=0.05)
    assert result.ks["road_V"] < result.start_ks["road_V"]
    for budget in (1, 2, 7):
        assert calibrate_profile(_synthetic(truth), fit=fit, max_replays=budget).evaluations == budget


def test_the_world_fields_are_searched_by_rendering_within_their_budget(synthetic):
    truth = CameraProfile(exposure_bias_ev=0.8, asphalt_scale=1.4)
    result = calibrate_profile(_synthetic(truth), fit=("exposure_bias_ev", "asphalt_scale"), max_evaluations=12)
    assert 2 <= result.renders <= 12 and result.renders == len(synthetic)
    assert result.evaluations > result.renders  # the camera's field on the recorded renders
    assert result.objective < 0.05 < result.start_objective
    assert result.profile.asphalt_scale == pytest.approx(1.4, abs=0.1)
    assert result.profile.exposure_bias_ev == pytest.approx(0.8, abs=0.1)
    assert all(p.exposure_bias_ev == 0.0 for p in synthetic[:1])  # the first render is the start's
    one = calibrate_profile(_synthetic(truth), fit=("asphalt_scale",), max_evaluations=1)
    assert one.renders == 1 and one.profile == CameraProfile()


# --- refusals before rendering -----------------------------------------------------


@pytest.fixture
def no_rendering(monkeypatch):
    def fail(*args, **kwargs):
        raise AssertionError("rendered before refusing")

    monkeypatch.setattr(calibrate_module, "collect_frames", fail)
    monkeypatch.setattr(calibrate_module, "record_worlds", fail)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"fit": ("exposure",)}, "fit: unknown value 'exposure'"),
        ({"max_evaluations": 0}, "max_evaluations"),
        ({"max_replays": 0}, "max_replays"),
        ({"workers": 0}, "workers"),
        ({"frames": 0}, "frames"),
        ({"scenarios": ("racetrak",)}, "Did you mean 'racetrack'"),
        ({"seeds": ()}, "seeds"),
        ({"env_options": {"camera_profile": TRUTH}}, "env_options: camera_profile is set by the calibration"),
        ({"start": "default"}, "start: expected a CameraProfile"),
    ],
)
def test_bad_arguments_are_refused_by_name(no_rendering, kwargs, words):
    with pytest.raises(InvalidParameterError) as info:
        calibrate_profile(_values(), **kwargs)
    assert words in str(info.value)


def test_a_reference_without_values_is_refused(no_rendering):
    with pytest.raises(InvalidParameterError, match="reference: no finite value of"):
        calibrate_profile(dict(_values(), saturated=[np.nan]))


def test_photo_folders_are_refused_by_name(no_rendering, tmp_path):
    with pytest.raises(InvalidParameterError, match=r"photos: .* is not a directory"):
        calibrate_from_photos(tmp_path / "nowhere", tmp_path)
    with pytest.raises(InvalidParameterError, match="photos: no image in"):
        calibrate_from_photos(tmp_path, tmp_path)


def test_write_calibration_refuses_a_path_that_is_not_toml(tmp_path):
    with pytest.raises(InvalidParameterError, match=r"out: .*expected a name ending in one of \.toml"):
        write_calibration(None, tmp_path / "camera.json")  # type: ignore[arg-type]


# --- real renders ------------------------------------------------------------------


def _write_photos(root, values_profile, seeds, scenarios=("racetrack", "winding")):
    """Frames simroad renders with ``values_profile`` as PNG photos and 0/255 masks."""
    from simroad.experiments.frames import collect_frames

    fs = collect_frames(
        scenarios=scenarios, seeds=seeds, frames_per_seed=3, every=5, env_options={"camera_profile": values_profile}
    )
    photos, masks = root / "photos", root / "masks"
    photos.mkdir()
    masks.mkdir()
    for k, (rgb, road, src) in enumerate(zip(fs.images, fs.masks, fs.source)):
        if src[2] == 0:  # the first frame, before the exposure settles, as calibrate leaves it out
            continue
        cv2.imwrite(str(photos / f"p{k:03d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(masks / f"p{k:03d}.png"), road.astype(np.uint8) * 255)
    return photos, masks


def test_profile_statistics_change_with_the_profile():
    small = {"scenarios": ("highway",), "seeds": (6000,), "frames": 1}
    base = profile_statistics(CameraProfile(), **small)
    bright = profile_statistics(CameraProfile(exposure_bias_ev=1.0), **small)
    assert base["road_V"].size == 1
    assert bright["road_V"][0] > base["road_V"][0] + 0.05 and bright["frame_V"][0] > base["frame_V"][0]


@pytest.mark.slow
def test_a_short_fit_writes_a_profile_that_loads(tmp_path):
    photos, masks = _write_photos(tmp_path, TRUTH, (7000,), scenarios=("highway",))
    result = calibrate_from_photos(
        photos, masks, fit=("exposure_bias_ev",), scenarios=("highway",), seeds=(6000,), frames=1, max_replays=4
    )
    assert 2 <= result.evaluations <= 4 and result.renders == 1 and result.photos == 2 and result.frames == 1
    assert result.objective <= result.start_objective and result.fitted == ("exposure_bias_ev",)
    assert dataclasses.replace(result.profile, exposure_bias_ev=0.0) == CameraProfile()  # only the fitted field moved
    text = format_calibration(result)
    assert "KS start" in text and all(s in text for s in STATISTICS)
    path = write_calibration(result, tmp_path / "sub" / "camera.toml")
    assert load_profile(path) == result.profile
    header = path.read_text().split("[camera_profile]")[0]
    assert str(photos) in header and "objective:" in header and "road_V" in header


@pytest.mark.slow
def test_recovers_a_known_profile_from_frames_it_rendered(tmp_path):
    """Photos from worlds 7000-7003, the fit on worlds 6000-6001: the objective falls by
    40 % or more, the field the statistics pin down best -- the exposure (brightness) --
    moves most of the way to the truth, and the road's tint comes closer to the photos'.
    Sized for a test
    (16 photos, 8 frames per evaluation), where the contrast and the asphalt trade off
    within the sampling noise; benchmarks/calibration_check.py runs the acceptance check
    at size (200 photos). Six renders of the four worlds, the rest replays."""
    photos, masks = _write_photos(tmp_path, TRUTH, range(7000, 7004))
    result = calibrate_from_photos(
        photos,
        masks,
        fit=FOUR,
        scenarios=("racetrack", "winding"),
        seeds=(6000, 6001),
        frames=2,
        max_evaluations=6,
        max_replays=150,
    )
    assert result.photos == 16 and result.frames == 8
    # At this size the objective has a floor near half the start's (8 frames against 16
    # photos: measured 3.96 -> 1.95 with 150 replays): a fit that gets most of the way there.
    assert result.objective < 0.6 * result.start_objective
    fitted, default = result.profile, CameraProfile()
    assert abs(fitted.exposure_bias_ev - TRUTH.exposure_bias_ev) < 0.5 * abs(default.exposure_bias_ev - 0.8)
    # The white balance preset itself is not pinned down at this size: the camera's AWB
    # takes 55 % of the way to each scene's light and errs by 15 mired per episode, so
    # 16 photos leave the preset within the sampling noise (this fit: 5595 K for a truth
    # of 4200 K). What it sets, the road's tint, does come closer to the photos'.
    assert result.ks["road_b"] < result.start_ks["road_b"]
