"""Shared input checks (simroad._validation)."""

from __future__ import annotations

import numpy as np
import pytest

from simroad._validation import SimroadError, check_array, check_image


# --- check_array and the finite-value message (issue 13, models) ---------------------------------
def test_check_array_returns_valid_arrays_uncopied():
    a = np.linspace(-5, 5, 12, dtype=np.float32).reshape(3, 4)
    assert check_array("x", a, ndim=2) is a
    i = np.arange(3)
    assert check_array("i", i, dtype="int64", ndim=1) is i


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        ([1.0, 2.0], {}, r"^x: expected a numpy array, got list"),
        (np.zeros(3, np.int16), {}, r"^x: expected dtype float32 or float64, got int16"),
        (np.zeros((2, 2)), {"ndim": 1}, r"^x: expected an array with 1 dimensions, got shape \(2, 2\)"),
        (np.zeros((0, 3)), {}, r"^x: expected a non-empty array"),
        (np.array([1.0, np.nan, np.inf]), {}, r"^x: expected finite values, got 2 NaN or infinite value\(s\)"),
    ],
)
def test_check_array_refuses_by_name(value, kwargs, match):
    with pytest.raises(SimroadError, match=match):
        check_array("x", value, **kwargs)


def test_check_image_names_non_finite_values():
    img = np.full((4, 4, 3), 0.5, np.float32)
    img[1, 2, 0] = -np.inf
    with pytest.raises(SimroadError, match=r"^image: expected finite values, got 1 NaN or infinite value\(s\)"):
        check_image("image", img)
