"""The error family: each situation raises its own class, which a caller can catch apart,
and every one is a SimroadError and the built-in exception Python code expects."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from simroad import errors
from simroad.core.validation import check_in_range, check_int_in_range
from simroad.detector import RoadDetector
from simroad.detector.registry import predict_alone
from simroad.errors import (
    DetectorFailedError,
    InvalidParameterError,
    MissingDependencyError,
    ModelFileError,
    OutputInUseError,
    ResetNeededError,
    SimroadError,
)
from simroad.experiments._ray_backend import run_on_ray
from simroad.experiments.outlock import OutputLock
from simroad.noise import RainModel

#: Every subclass simroad.errors exports (a new one must get a case below).
FAMILY = tuple(getattr(errors, name) for name in errors.__all__ if name != "SimroadError")


class _Raises:
    def predict(self, image):
        raise ZeroDivisionError("a bug in the detector")


def _raised(fn):
    with pytest.raises(SimroadError) as caught:
        fn()
    return caught.value


def _no_ray(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray now raises ImportError
    return run_on_ray([], workers=1, address=None, cell_fn=lambda spec: {})


CASES = [
    (InvalidParameterError, ValueError, lambda tmp, mp: check_in_range("severity", 2.0, 0.0, 1.0)),
    (InvalidParameterError, TypeError, lambda tmp, mp: check_int_in_range("steps", "ten", 1, 10)),
    (
        ResetNeededError,
        RuntimeError,
        lambda tmp, mp: RainModel.from_severity(0.5).apply(np.zeros((32, 32, 3), np.uint8)),
    ),
    (
        ModelFileError,
        ValueError,
        lambda tmp, mp: RoadDetector.load((tmp / "m.npz").write_bytes(b"not a zip") and tmp / "m.npz"),
    ),
    (OutputInUseError, RuntimeError, lambda tmp, mp: (OutputLock(tmp).acquire(), OutputLock(tmp).acquire())),
    (MissingDependencyError, ImportError, lambda tmp, mp: list(_no_ray(mp))),
    (DetectorFailedError, RuntimeError, lambda tmp, mp: predict_alone(_Raises(), np.zeros((8, 8, 3), np.uint8))),
]


@pytest.mark.parametrize(
    ("cls", "builtin", "make"),
    CASES,
    ids=["value", "type", "reset", "model-file", "output-in-use", "missing-extra", "detector-failed"],
)
def test_each_situation_raises_its_own_class(cls, builtin, make, tmp_path, monkeypatch):
    err = _raised(lambda: make(tmp_path, monkeypatch))
    assert type(err) is cls
    assert isinstance(err, builtin)
    others = [c for c in FAMILY if c is not cls]
    assert not isinstance(err, tuple(others)), "caught apart: no error is two of the family"


def test_every_class_of_the_family_has_a_case():
    assert {cls for cls, _, _ in CASES} == set(FAMILY)


def test_a_detector_failure_names_the_detector_and_where_it_raised():
    with pytest.raises(DetectorFailedError, match=r"'_Raises': predict\(\) raised ZeroDivisionError: a bug in the "
                       r"detector at test_errors\.py:\d+") as caught:  # fmt: skip
        predict_alone(_Raises(), np.zeros((8, 8, 3), np.uint8))
    assert isinstance(caught.value.__cause__, ZeroDivisionError)


def test_the_command_line_turns_a_bad_value_into_exit_2(capsys):  # a failed detector: 3 (test_failing_detector)
    from simroad.cli.main import main

    assert main(["episode", "--steps", "0"]) == 2
    assert "steps" in capsys.readouterr().err
