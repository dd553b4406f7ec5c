"""filter_effect: the detector with and without a filter on real rendered weather, and
the paired interval of its difference on hand-built frames whose counts are known."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import simroad.experiments.filter_effect as fe
from simroad import SimroadError
from simroad.cli.main import main
from simroad.detector import RoadDetector
from simroad.envs import SCENARIO_NAMES
from simroad.experiments.filter_effect import filter_effect, filter_effect_table, format_filter_effect
from simroad.experiments.frames import FrameSet
from simroad.experiments.stats import paired_pooled_difference


@pytest.fixture(scope="module")
def cache():
    return {}


@pytest.mark.slow
def test_light_filter_lowers_fnr_plus_fpr_under_strong_glare(cache):
    row = filter_effect("glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache)
    assert row["frames"] == 2 * 3 * len(SCENARIO_NAMES)  # seeds x frames x scenarios
    off, on = row["without"], row["with"]
    assert off["fnr"] > 0.2  # glare really hurts the unfiltered detector
    assert on["fnr"] + on["fpr"] < off["fnr"] + off["fpr"]
    assert row["better"] is True


@pytest.mark.slow
def test_paper_light_filter_leaves_grey_asphalt_glare_in_place(cache):
    """Eq. 27 cannot separate white light from grey asphalt: the paper's variant gains nothing."""
    paper = filter_effect(
        "glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache,
        detector_factory=lambda f: RoadDetector.pretrained(filters=f, filter_variant="paper"),
    )  # fmt: skip
    improved = filter_effect("glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache)
    # same frames; the unfiltered detectors differ only in the improved morphology's
    # lane-marking split, which moves a glare frame's FPR by a few tenths of a percent
    assert abs(paper["without"]["fnr"] - improved["without"]["fnr"]) < 0.01
    gain = lambda r: (r["without"]["fnr"] + r["without"]["fpr"]) - (r["with"]["fnr"] + r["with"]["fpr"])  # noqa: E731
    assert gain(improved) > gain(paper) + 0.05


@pytest.mark.slow
def test_improved_rain_snow_filter_lifts_the_snow_veil(cache):
    """In snow the haze, not the flakes, costs the far road: the improved rain/snow
    filter (haze removal first) must lower FNR + FPR, and by more than the paper's."""
    improved = filter_effect("snow", ["rain_snow"], seeds=(110, 111), frames=3, severity=0.7, cache=cache)
    off, on = improved["without"], improved["with"]
    assert off["fnr"] > 0.05  # snow really hurts the unfiltered detector
    assert on["fnr"] < off["fnr"] and on["fnr"] + on["fpr"] < off["fnr"] + off["fpr"]
    paper = filter_effect(
        "snow", ["rain_snow"], seeds=(110, 111), frames=3, severity=0.7, cache=cache,
        detector_factory=lambda f: RoadDetector.pretrained(filters=f, filter_variant="paper"),
    )  # fmt: skip
    total = lambda r: r["with"]["fnr"] + r["with"]["fpr"]  # noqa: E731
    assert total(improved) < total(paper)


@pytest.mark.slow
def test_table_rows_and_format(cache):
    rows = filter_effect_table(seeds=(110,), frames=2, severity=0.6, noises=("shadow",), cache=cache)
    assert [(r["noise"], r["filters"]) for r in rows] == [
        ("shadow", ("shadow",)),
        ("shadow", ("rain_snow", "light", "shadow")),
    ]
    text = format_filter_effect(rows)
    assert text.splitlines()[0].split()[:2] == ["noise", "filters"] and len(text.splitlines()) == 3


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"noise": "glare", "filters": []}, "filters: expected at least one filter"),
        ({"noise": "glare", "filters": ["light"], "seeds": []}, "seeds: expected at least one seed"),
        ({"noise": "glare", "filters": ["light"], "severity": 1.5}, "severity"),
        ({"noise": "glare", "filters": ["fog"]}, "filters"),
    ],
)
def test_bad_protocol_is_a_clear_error(kwargs, match):
    with pytest.raises(SimroadError, match=match):
        filter_effect(**kwargs)


# -- the paired interval on hand-built frames -------------------------------------------
# A frame is 1 x 10 pixels, all ground: pixels 0-4 road, 5-9 not. Channel 0 of the image
# is the unfiltered detector's mask, channel 1 the filtered one's, so each frame's
# counts are chosen by hand: (m, f) = road pixels missed, non-road pixels called road.


class _ChannelDetector:
    """Predicts the mask stored in one channel of the image."""

    def __init__(self, channel: int):
        self.channel = channel

    def predict(self, image: np.ndarray) -> np.ndarray:
        return image[..., self.channel] > 0


def _factory(filters):
    return _ChannelDetector(1 if filters else 0)


def _frame(off: tuple[int, int], on: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    image = np.zeros((1, 10, 3), np.uint8)
    for channel, (missed, false_road) in enumerate((off, on)):
        image[0, missed:5, channel] = 1
        image[0, 5 : 5 + false_road, channel] = 1
    gt = np.zeros((1, 10), bool)
    gt[0, :5] = True
    return image, gt


def _frame_set(episodes: dict[tuple[str, int], list[tuple[tuple[int, int], tuple[int, int]]]]) -> FrameSet:
    """Frames of each (scenario, seed) episode, in order: ``[(off (m, f), on (m, f)), ...]``."""
    out = FrameSet()
    for (scenario, seed), frames in episodes.items():
        for i, (off, on) in enumerate(frames):
            image, gt = _frame(off, on)
            out.images.append(image)
            out.masks.append(gt)
            out.noise_masks.append({})
            out.valid.append(np.ones_like(gt))
            out.source.append((scenario, seed, 4 * i))
    return out


def _run(monkeypatch, episodes, factory=_factory) -> dict:
    frames = _frame_set(episodes)
    monkeypatch.setattr(fe, "collect_frames", lambda **kw: frames)
    return filter_effect("rain", ["rain_snow"], seeds=(100,), frames=1, detector_factory=factory)


#: Three episodes of 1, 3 and 2 frames; see test_paired_difference_by_hand.
HAND = {
    ("racetrack", 100): [((2, 1), (0, 0))],
    ("racetrack", 101): [((1, 0), (1, 1)), ((1, 0), (1, 0)), ((1, 0), (1, 0))],
    ("highway", 100): [((3, 2), (1, 1)), ((2, 2), (1, 1))],
}


def test_paired_difference_by_hand(monkeypatch):
    row = _run(monkeypatch, HAND)
    assert row["frames"] == 6 and row["episodes"] == 3
    # 6 frames: 30 road and 30 non-road pixels. Without: 10 missed, 5 false road;
    # with: 5 missed, 3 false road.
    assert row["without"] == pytest.approx({"fnr": 10 / 30, "fpr": 5 / 30})
    assert row["with"] == pytest.approx({"fnr": 5 / 30, "fpr": 3 / 30})
    # ratio of sums: (8 - 15) / 30, not the mean of the episodes' own differences
    # (-3/5, +1/15, -1/2: mean -0.344)
    assert row["diff"] == pytest.approx(-7 / 30, abs=1e-15)
    # Every rate's denominator is 5 per frame, so a resample's difference is a weighted
    # mean of the episodes' own ones; three episodes: each all-one-episode resample has
    # probability 1/27 > 2.5 %, so the ends are the smallest and the largest of them.
    assert (row["diff_lo"], row["diff_hi"]) == pytest.approx((-3 / 5, 1 / 15), abs=1e-12)
    assert row["diff_lo"] <= row["diff"] <= row["diff_hi"]
    assert row["better"] is True and row["resolved"] is False


def test_the_same_detector_twice_differs_by_zero(monkeypatch):
    row = _run(monkeypatch, HAND, factory=lambda filters: _ChannelDetector(0))
    assert row["without"] == row["with"]
    assert (row["diff"], row["diff_lo"], row["diff_hi"]) == (0.0, 0.0, 0.0)
    assert row["better"] is False and row["resolved"] is False


def test_the_bootstrap_resamples_episodes_not_frames(monkeypatch):
    # The filter helps in one world (2 of 5 road pixels found again in each of 50
    # frames) and hurts in the other (1 of 5 lost): pooled -0.1.
    helps, hurts = ((2, 0), (0, 0)), ((0, 0), (1, 0))
    row = _run(monkeypatch, {("racetrack", 100): [helps] * 50, ("racetrack", 101): [hurts] * 50})
    assert row["diff"] == pytest.approx(-0.1, abs=1e-15) and row["better"] is True
    # Two episodes: resamples AA, AB, BB (1/4, 1/2, 1/4): the interval is [A's, B's].
    assert (row["diff_lo"], row["diff_hi"]) == pytest.approx((-0.4, 0.2), abs=1e-12)
    assert row["resolved"] is False
    # The 100 frames taken as independent units would claim a resolved gain.
    per_frame = lambda m, f: [5 - m, f, m, 5 - f]  # noqa: E731
    on = [per_frame(*on) for _, on in [helps] * 50 + [hurts] * 50]
    off = [per_frame(*off) for off, _ in [helps] * 50 + [hurts] * 50]
    _, _, frames_hi = paired_pooled_difference(on, off)
    assert frames_hi < 0.0


def test_a_resolved_gain(monkeypatch):
    # every one of four worlds gains, by different amounts
    row = _run(monkeypatch, {("town", s): [((1 + s % 3, 1), (0, 1))] * 2 for s in range(100, 104)})
    assert row["diff_hi"] < 0.0 and row["better"] is True and row["resolved"] is True


def test_one_episode_has_no_interval(monkeypatch):
    row = _run(monkeypatch, {("winding", 100): [((2, 0), (1, 0))] * 3})
    assert row["episodes"] == 1 and row["diff"] == pytest.approx(-0.2, abs=1e-15)
    assert math.isnan(row["diff_lo"]) and math.isnan(row["diff_hi"])
    assert row["better"] is True and row["resolved"] is False
    assert format_filter_effect([row]).splitlines()[1].split()[7:] == ["-20.00", "(n=1)", "yes", "no"]


def test_the_table_shows_the_difference_in_points(monkeypatch):
    row = _run(monkeypatch, HAND)
    head, line = format_filter_effect([row]).splitlines()
    assert "Δ [95 % CI]" in head and head.split()[-2:] == ["better", "resolved"]
    assert line.split() == ["rain", "rain_snow", "6", "33.33", "16.67", "16.67", "10.00",
                            "-23.33", "[-60.00,", "+6.67]", "yes", "no"]  # fmt: skip


def test_frames_without_their_source_are_a_clear_error(monkeypatch):
    frames = _frame_set(HAND)
    frames.source = frames.source[:-1]
    monkeypatch.setattr(fe, "collect_frames", lambda **kw: frames)
    with pytest.raises(SimroadError, match=r"frames\.source"):
        filter_effect("rain", ["rain_snow"], seeds=(100,), frames=1, detector_factory=_factory)


def test_cli_json_carries_the_interval_on_a_second_set_of_worlds(monkeypatch, capsys):
    asked = []

    def collect(*, scenarios, seeds, frames_per_seed, **kw):
        asked.append(tuple(seeds))
        gain = lambda seed: ((2, 1), (1 + seed % 2, 0))  # noqa: E731
        return _frame_set({(sc, s): [gain(s)] * frames_per_seed for sc in scenarios for s in seeds})

    monkeypatch.setattr(fe, "collect_frames", collect)
    monkeypatch.setattr(RoadDetector, "pretrained", staticmethod(lambda filters, filter_variant: _factory(filters)))
    args = ["filter-effect", "--noises", "rain", "--seeds", "2", "--seed-start", "110", "--frames", "2"]
    assert main([*args, "--severity", "0.5", "--json"]) == 0
    assert asked == [(110, 111)]  # the disjoint worlds
    (out,) = json.loads(capsys.readouterr().out)
    row = out["rows"][0]
    assert row["episodes"] == 2 * len(SCENARIO_NAMES) and row["frames"] == 2 * row["episodes"]
    # without 2/5 + 1/5 in every frame; with 1/5 (seed 110) or 2/5 (111), half the frames each
    assert row["diff"] == pytest.approx(-0.3, abs=1e-12)
    assert row["diff_lo"] <= row["diff"] <= row["diff_hi"] < 0 and row["resolved"] is True
    assert main([*args, "--severity", "0.5"]) == 0
    assert "Δ [95 % CI]" in capsys.readouterr().out
