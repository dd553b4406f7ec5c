"""The material table: sourced ranges, valid draws."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.camera.materials import ALBEDO, draw_albedo
from simroad.errors import SimroadError


def test_every_range_is_ordered_physical_and_sourced():
    for name, r in ALBEDO.items():
        lo, hi = np.asarray(r.lo), np.asarray(r.hi)
        assert np.all(0.0 < lo) and np.all(lo <= hi) and np.all(hi < 1.0), name
        assert r.source, f"{name} has no source"


def test_published_orderings_hold():
    """Fresh asphalt < aged asphalt < concrete < fresh snow (Oke 1987; Pomerantz et al. 2000)."""

    def mid(n):
        return float(np.mean(np.add(ALBEDO[n].lo, ALBEDO[n].hi)) / 2)

    assert mid("asphalt_fresh") < 0.07 < mid("asphalt_aged") < mid("concrete_aged") < mid("concrete") < mid("snow")
    assert mid("snow_old") < mid("snow") and mid("soil_wet") < mid("soil")
    g = np.add(ALBEDO["grass"].lo, ALBEDO["grass"].hi)
    assert g[1] > g[0] > g[2]  # green peak, chlorophyll absorbs red and blue


def test_draws_are_reproducible_and_within_tinted_range():
    for name, r in ALBEDO.items():
        a = draw_albedo(name, np.random.default_rng(7))
        b = draw_albedo(name, np.random.default_rng(7))
        np.testing.assert_array_equal(a, b)
        assert a.dtype == np.float32 and a.shape == (3,)
        assert np.all(a >= np.asarray(r.lo) * (1 - 5 * r.tint)) and np.all(a <= np.asarray(r.hi) * (1 + 5 * r.tint))


def test_unknown_material_is_refused_with_a_suggestion():
    with pytest.raises(SimroadError, match=r"material.*asphalt_aged"):
        draw_albedo("asphalt_old", np.random.default_rng(0))
