"""The documentation figures are drawn by the project itself, from real episodes."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simroad.envs import SCENARIO_NAMES
from simroad.errors import SimroadError
from simroad.experiments.figures import places_figure

pytestmark = pytest.mark.slow


def test_places_figure_shows_every_scenario_clean_and_in_low_sun(tmp_path) -> None:
    path = places_figure(tmp_path / "places.png", seed=3, steps=2)
    img = cv2.imread(str(path))
    assert img is not None
    # 12.8 in wide at 80 dpi; 3.7 in per scenario row.
    assert img.shape[1] == 1024
    assert img.shape[0] == pytest.approx(3.7 * 80 * len(SCENARIO_NAMES), abs=2)
    # Every row holds two photographs, not blank panels: plenty of distinct colours.
    rows = np.array_split(img, len(SCENARIO_NAMES), axis=0)
    for row in rows:
        assert len(np.unique(row.reshape(-1, 3), axis=0)) > 500


def test_places_figure_refuses_a_bad_destination(tmp_path) -> None:
    with pytest.raises(SimroadError, match="out"):
        places_figure(tmp_path / "places.xyz")
