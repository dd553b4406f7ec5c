"""The shared input checks of simroad.core.validation (each engineer adds tests for their checkers)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from simroad.core.validation import (
    check_array,
    check_bool,
    check_fields_in_range,
    check_image,
    check_mask,
    check_output_dir,
    check_output_file,
    normalize_rng,
)
from simroad.errors import SimroadError


# --- check_array and the finite-value message ---------------------------------------------
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


@pytest.mark.parametrize("value", [True, False, np.bool_(True), np.bool_(False)])
def test_check_bool_accepts_bools(value):
    assert check_bool("flag", value) is bool(value)


@pytest.mark.parametrize("value", ["yes", "no", "False", 0, 1, 2, None, 1.0, [True]])
def test_check_bool_refuses_everything_else_by_name(value):
    with pytest.raises(SimroadError, match=r"^flag: expected True or False"):
        check_bool("flag", value)


def test_check_output_dir_creates_nothing(tmp_path):
    target = tmp_path / "a" / "b"
    assert check_output_dir("out", target) == target
    assert not (tmp_path / "a").exists()


def test_check_output_dir_refuses_a_file_and_paths_below_one(tmp_path):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    with pytest.raises(SimroadError, match=r"^out: .* is a file, not a directory"):
        check_output_dir("out", blocker)
    with pytest.raises(SimroadError, match=r"^out: .* lies below .*file\.txt'"):
        check_output_dir("out", blocker / "sub" / "dir")
    with pytest.raises(SimroadError, match=r"^out: expected a directory path, got int 5"):
        check_output_dir("out", 5)


def test_check_output_file(tmp_path):
    assert check_output_file("figure", tmp_path / "new" / "f.png", suffixes=(".png",)).name == "f.png"
    assert not (tmp_path / "new").exists()
    with pytest.raises(SimroadError, match=r"^figure: .* is a directory"):
        check_output_file("figure", tmp_path)
    with pytest.raises(SimroadError, match=r"^figure: cannot write .*'\.xyz' is not supported; .*\.png"):
        check_output_file("figure", tmp_path / "f.xyz", suffixes=(".png", ".pdf"))
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(SimroadError, match=r"^figure: .*file\.txt"):
        check_output_file("figure", tmp_path / "file.txt" / "f.png")
    with pytest.raises(SimroadError, match=r"^figure: expected a file path"):
        check_output_file("figure", "")


@pytest.mark.parametrize("shape", [(0, 0), (0, 5), (5, 0)])
def test_check_mask_refuses_empty_masks(shape):
    with pytest.raises(SimroadError, match=r"^mask: expected a mask of at least 1x1 pixels, got shape"):
        check_mask("mask", np.zeros(shape, bool))


@pytest.mark.parametrize("seed", [-1, np.int64(-7), -(2**70)])
def test_normalize_rng_refuses_negative_seeds_by_name(seed):
    with pytest.raises(SimroadError, match=r"^random_state: expected a seed >= 0, got -"):
        normalize_rng(seed, name="random_state")


def test_normalize_rng_keeps_valid_seeds():
    assert normalize_rng(0).random() == np.random.default_rng(0).random()
    assert normalize_rng(np.uint64(2**63)).random() == np.random.default_rng(2**63).random()


def test_check_input_dir_and_file(tmp_path):
    from simroad.core.validation import check_input_dir, check_input_file

    f = tmp_path / "f.txt"
    f.write_text("x")
    assert check_input_dir("dir", tmp_path) == tmp_path and check_input_file("config", f) == f
    with pytest.raises(SimroadError, match=r"^dir: .* is not a directory"):
        check_input_dir("dir", f)
    with pytest.raises(SimroadError, match=r"^dir: .* does not exist"):
        check_input_dir("dir", tmp_path / "missing")
    with pytest.raises(SimroadError, match=r"^config: .* is not a regular file"):
        check_input_file("config", tmp_path)
    with pytest.raises(SimroadError, match=r"^config: expected a file path, got int 5"):
        check_input_file("config", 5)


def test_check_fields_in_range_checks_in_table_order():
    ranges = {"a_m": (0.0, 1.0, "m", False), "b": (0.0, 1.0, "", True)}
    assert check_fields_in_range(SimpleNamespace(a_m=1, b=0), ranges) == {"a_m": 1.0, "b": 0.0}
    with pytest.raises(SimroadError, match=r"a_m: expected a value in \(0, 1\] m, got 0 m"):
        check_fields_in_range(SimpleNamespace(a_m=0, b=2), ranges)
    with pytest.raises(SimroadError, match=r"b: expected a value in \[0, 1\), got 1"):
        check_fields_in_range(SimpleNamespace(a_m=1, b=1), ranges, high_exclusive=("b",))
