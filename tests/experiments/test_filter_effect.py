"""filter_effect: the detector with and without a filter on real rendered weather."""

from __future__ import annotations

import pytest

from simroad import SimroadError
from simroad.detector import RoadDetector
from simroad.envs import SCENARIO_NAMES
from simroad.experiments.filter_effect import filter_effect, filter_effect_table, format_filter_effect


@pytest.fixture(scope="module")
def cache():
    return {}


def test_light_filter_lowers_fnr_plus_fpr_under_strong_glare(cache):
    row = filter_effect("glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache)
    assert row["frames"] == 2 * 3 * len(SCENARIO_NAMES)  # seeds x frames x scenarios
    off, on = row["without"], row["with"]
    assert off["fnr"] > 0.2  # glare really hurts the unfiltered detector
    assert on["fnr"] + on["fpr"] < off["fnr"] + off["fpr"]
    assert row["better"] is True


def test_paper_light_filter_leaves_grey_asphalt_glare_in_place(cache):
    """Eq. 27 cannot separate white light from grey asphalt: the paper's variant gains nothing."""
    paper = filter_effect(
        "glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache,
        detector_factory=lambda f: RoadDetector.pretrained(filters=f, filter_variant="paper"),
    )  # fmt: skip
    improved = filter_effect("glare", ["light"], seeds=(110, 111), frames=3, severity=0.7, cache=cache)
    assert paper["without"] == improved["without"]  # same frames, same unfiltered detector
    gain = lambda r: (r["without"]["fnr"] + r["without"]["fpr"]) - (r["with"]["fnr"] + r["with"]["fpr"])  # noqa: E731
    assert gain(improved) > gain(paper) + 0.05


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
