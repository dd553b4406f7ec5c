"""Every exported callable of simroad.detector refuses bad input by name.

The table is keyed by ``simroad.detector.__all__``: an exported callable without an
entry (or a reason it takes no input) fails :func:`test_every_export_has_an_entry`.
Each function taking arrays has at least one wrong type, one out-of-range value and one
non-finite array; each must end in a :class:`SimroadError` (a ``ValueError``) whose
message starts with the parameter's name.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import simroad.detector as D
import simroad.filters as F
from simroad.errors import SimroadError

IMG = np.random.default_rng(0).integers(0, 256, (12, 12, 3), dtype=np.uint8)
MASK = np.zeros((12, 12), bool)
MASK[4:, 3:9] = True


def _with(value: float, shape: tuple[int, ...], fill: float = 0.5) -> np.ndarray:
    a = np.full(shape, fill, np.float64)
    a[(1,) * len(shape)] = value
    return a


NAN_IMG = _with(np.nan, (12, 12, 3)).astype(np.float32)
BIG_IMG = _with(1.5, (12, 12, 3)).astype(np.float32)
SV = np.random.default_rng(1).normal(size=(5, 3))
COEF = np.array([1.0, -1.0, 0.5, -0.5, 0.2])

Case = tuple[str, Callable[[], object], str]  # (kind, call, parameter named in the error)


def _image_cases(fn: Callable[[object], object]) -> list[Case]:
    return [
        ("type", lambda: fn(IMG.tolist()), "image"),
        ("type-dtype", lambda: fn(IMG.astype(np.int32)), "image"),
        ("range", lambda: fn(BIG_IMG), "image"),
        ("finite", lambda: fn(NAN_IMG), "image"),
    ]


def _mask_cases(fn: Callable[[object], object]) -> list[Case]:
    two = MASK.astype(np.int64)
    two[0, 0] = 2
    return [
        ("type", lambda: fn(MASK.tolist()), "mask"),
        ("type-shape", lambda: fn(np.stack([MASK, MASK], axis=-1)), "mask"),
        ("range", lambda: fn(two), "mask"),
        ("finite", lambda: fn(_with(np.nan, (12, 12), 1.0)), "mask"),
        ("range-empty", lambda: fn(np.zeros((0, 0), bool)), "mask"),  # was a segfault in OpenCV
        ("range-no-rows", lambda: fn(np.zeros((0, 12), bool)), "mask"),
    ]


def _pretrained() -> D.RoadDetector:
    return D.RoadDetector.pretrained()


class _Camera:
    def __init__(self, ground_valid: object) -> None:
        self.ground_valid = ground_valid


#: Exported callables that take no input (and why); everything else is in CASES.
NOT_ARRAY_FUNCTIONS = {"default_model_path": "takes no arguments"}

#: Exported callables that take paths, not arrays: type and range cases only.
PATH_FUNCTIONS = {"check_model_destination"}


def _below_a_file(tmp: Path) -> Path:
    (tmp / "plain-file").write_text("x")
    return tmp / "plain-file" / "m.npz"


CASES: dict[str, list[Case]] = {
    "KernelExpansion": [
        ("type", lambda: D.KernelExpansion(SV.tolist(), COEF, 0.0, 1.0), "support_vectors"),
        ("type-dual_coef", lambda: D.KernelExpansion(SV, COEF.astype(np.int64), 0.0, 1.0), "dual_coef"),
        ("type-intercept", lambda: D.KernelExpansion(SV, COEF, "0", 1.0), "intercept"),
        ("range", lambda: D.KernelExpansion(SV, COEF, 0.0, -1.0), "gamma"),
        ("range-dual_coef", lambda: D.KernelExpansion(SV, COEF[:3], 0.0, 1.0), "dual_coef"),
        ("range-empty", lambda: D.KernelExpansion(SV[:0], COEF[:0], 0.0, 1.0), "support_vectors"),
        ("finite", lambda: D.KernelExpansion(_with(np.nan, (5, 3)), COEF, 0.0, 1.0), "support_vectors"),
        ("finite-gamma", lambda: D.KernelExpansion(SV, COEF, 0.0, float("nan")), "gamma"),
        ("finite-coef", lambda: D.KernelExpansion(SV, _with(np.inf, (5,)), 0.0, 1.0), "dual_coef"),
        ("range-x", lambda: D.KernelExpansion(SV, COEF, 0.0, 1.0).decision_function(np.zeros((4, 2))), "x"),
        ("finite-x", lambda: D.KernelExpansion(SV, COEF, 0.0, 1.0).predict(_with(np.nan, (4, 3))), "x"),
    ],
    "RoadDetector": [
        ("type", lambda: _pretrained().predict(IMG.tolist()), "image"),
        ("range", lambda: _pretrained().predict(BIG_IMG), "image"),
        ("range-size", lambda: _pretrained().predict(IMG[:4]), "image"),
        ("finite", lambda: _pretrained().predict(NAN_IMG), "image"),
        ("type-load", lambda: D.RoadDetector.load(7), "path"),
        ("range-filters", lambda: D.RoadDetector.pretrained(filters=("fog",)), "filters"),
        ("finite-fit", lambda: D.RoadDetector().fit([NAN_IMG], [MASK]), "images[0]"),
        ("range-fit-C", lambda: D.RoadDetector(C=-1.0).fit([IMG], [MASK]), "C"),
        ("type-exact", lambda: _pretrained().predict(IMG, exact="no"), "exact"),  # 'no' ran the exact SVM
        ("range-fit-seed", lambda: D.RoadDetector(random_state=-1).fit([IMG], [MASK]), "random_state"),
        ("type-memory", lambda: _pretrained().predict_step(IMG, None), "memory"),
        ("type-ground", lambda: _pretrained().predict_step(IMG, D.GlareMemory(), ground=MASK.tolist()), "ground"),
        ("type-camera", lambda: _pretrained().episode("front"), "camera"),
    ],
    "DetectorEpisode": [
        ("type", lambda: D.DetectorEpisode(object()), "detector"),  # type: ignore[arg-type]
        ("type-image", lambda: _pretrained().episode().predict(IMG.tolist()), "image"),
        ("range", lambda: _pretrained().episode(_Camera(np.zeros((2, 12, 12), bool))), "camera"),
        ("range-size", lambda: _pretrained().episode().predict(IMG[:4]), "image"),
        ("finite", lambda: _pretrained().episode().predict(NAN_IMG), "image"),
    ],
    "GlareMemory": [
        ("type", lambda: D.GlareMemory(1.5), "since_lobe"),
        ("type-top", lambda: D.GlareMemory(0, "0.5"), "lobe_top"),
        ("range", lambda: D.GlareMemory(-1), "since_lobe"),
        ("range-top", lambda: D.GlareMemory(0, 1.5), "lobe_top"),
        ("finite", lambda: D.GlareMemory(0, float("nan")), "lobe_top"),
    ],
    "apply_filters": _image_cases(F.apply_filters),
    "check_model_destination": [
        ("type", lambda: D.check_model_destination(5), "path"),
        ("range", lambda: D.check_model_destination("/proc/no/such/dir/m.npz"), "path"),
    ],
    "extend_upward": [
        *[(kind, call, "road") for kind, call, _ in _mask_cases(lambda m: D.extend_upward(m, MASK))],
        ("type", lambda: D.extend_upward(MASK, MASK.tolist()), "seed"),
        ("range", lambda: D.extend_upward(MASK, MASK.astype(np.int64) * 2), "seed"),
        ("shape", lambda: D.extend_upward(MASK, MASK[:, :-1]), "seed"),
    ],
    "fill_holes": _mask_cases(D.fill_holes),
    "hsi": _image_cases(D.hsi),
    "keep_ego_component": _mask_cases(D.keep_ego_component),
    "pixel_features": _image_cases(D.pixel_features),
    "postprocess": _mask_cases(D.postprocess),
    "train_default": [
        ("type", lambda: D.train_default(5, [MASK], rng=0), "images"),
        ("type-image", lambda: D.train_default([IMG.tolist()], [MASK], rng=0), "images[0]"),
        ("type-rng", lambda: D.train_default([IMG], [MASK], rng="x"), "rng"),
        ("range", lambda: D.train_default([BIG_IMG], [MASK], rng=0), "images[0]"),
        ("range-mask", lambda: D.train_default([IMG], [MASK[:5]], rng=0), "masks[0]"),
        ("finite", lambda: D.train_default([NAN_IMG], [MASK], rng=0), "images[0]"),
    ],
}


def _exported_callables(module) -> set[str]:
    return {name for name in module.__all__ if callable(getattr(module, name))}


def test_every_export_has_an_entry():
    exported = _exported_callables(D) | {"apply_filters"}  # the filters' entry point, run in front of the detector
    assert exported - set(CASES) - set(NOT_ARRAY_FUNCTIONS) == set(), "add the new export to CASES"
    assert set(CASES) | set(NOT_ARRAY_FUNCTIONS) <= exported, "the table names something no longer exported"


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_function_has_each_kind_of_bad_input(name):
    kinds = {kind.split("-")[0] for kind, _, _ in CASES[name]}
    needed = {"type", "range"} if name in PATH_FUNCTIONS else {"type", "range", "finite"}
    assert needed <= kinds


@pytest.mark.parametrize(
    ("call", "param"),
    [
        pytest.param(call, param, id=f"{name}-{kind}")
        for name, cases in sorted(CASES.items())
        for kind, call, param in cases
    ],
)
def test_bad_input_is_refused_by_name(call, param):
    with pytest.raises(SimroadError) as info:
        call()
    assert isinstance(info.value, ValueError)
    assert str(info.value).startswith(f"{param}:"), str(info.value)


def test_a_path_below_a_regular_file_is_refused(tmp_path):
    with pytest.raises(SimroadError, match=r"^path: cannot write .* is a file, not a folder"):
        D.check_model_destination(_below_a_file(tmp_path))


def test_kernel_expansion_keeps_valid_float64_fields_as_given():
    ke = D.KernelExpansion(SV, COEF, 0.25, 2.0)
    assert ke.support_vectors is SV and ke.dual_coef is COEF
    assert ke.intercept == 0.25 and ke.gamma == 2.0
    assert D.KernelExpansion(SV.astype(np.float32), COEF, 0, 1).support_vectors.dtype == np.float64
