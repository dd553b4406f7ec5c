"""Grey-pixel statistics: the definition on hand-worked pixels, and its bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest

from simroad.errors import SimroadError
from simroad.metrics.colour import GreyCounts, grey_counts, grey_mask


def _px(*rgb: int) -> np.ndarray:
    return np.array([[rgb]], dtype=np.uint8)


@pytest.mark.parametrize(
    ("rgb", "grey"),
    [
        ((100, 100, 100), True),  # S = 0, V = 0.39
        ((30, 30, 30), False),  # V = 0.118 < 0.15: too dark
        ((230, 230, 230), False),  # V = 0.902 > 0.85: too bright
        ((120, 110, 105), True),  # S = 1 - 105/120 = 0.125 < 0.15
        ((120, 105, 100), False),  # S = 1 - 100/120 = 0.167 >= 0.15
        ((86, 118, 58), False),  # grass: S = 0.51
        ((200, 212, 225), False),  # pale sky: S = 0.11 but V = 0.882 > 0.85
    ],
)
def test_grey_definition_on_worked_pixels(rgb, grey) -> None:
    # OpenCV 8-bit HSV: V = max, S = 255 * (max - min) / max.
    v = max(rgb) / 255.0
    s = (max(rgb) - min(rgb)) / max(rgb)
    expected = s < 0.15 and 0.15 < v < 0.85
    assert bool(grey_mask(_px(*rgb))[0, 0]) == expected


def test_grey_counts_split_road_and_other() -> None:
    img = np.zeros((2, 3, 3), dtype=np.uint8)
    img[0] = (100, 100, 100)  # three grey pixels
    img[1] = (86, 118, 58)  # three green ones
    road = np.array([[True, True, False], [True, False, False]])
    c = grey_counts(img, road)
    assert c == GreyCounts(road=3, road_grey=2, other=3, other_grey=1)
    assert c.road_fraction == pytest.approx(2 / 3)
    assert c.other_fraction == pytest.approx(1 / 3)
    assert (c + c).road == 6
    assert np.isnan(GreyCounts().road_fraction)


def test_grey_counts_refuses_bad_input() -> None:
    with pytest.raises(SimroadError, match="road_mask"):
        grey_counts(np.zeros((4, 4, 3), np.uint8), np.zeros((3, 4), bool))
    with pytest.raises(SimroadError, match="rgb"):
        grey_mask(np.zeros((4, 4, 3), np.float32))
