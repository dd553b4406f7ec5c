"""Road-detector model files: checked arrays in a compressed ``.npz`` with a JSON header and a checksum, never pickled.

A shared model file therefore cannot run code, and a damaged one cannot load:
:func:`read_model` either returns exactly the arrays and parameters that were saved or
raises one :class:`~simroad.SimroadError` naming the file and what is wrong.
:meth:`RoadDetector.save <simroad.detector.RoadDetector.save>` and
:meth:`~simroad.detector.RoadDetector.load` use these functions.

Format (``meta["format"] == "simroad.RoadDetector"``)
-----------------------------------------------------
Version 2 (the current format): the arrays below, a JSON ``meta`` string
and ``checksum``, ``"sha256:<hex>"`` of every other array -- name, dtype, shape and
bytes, in name order (:func:`array_checksum`) -- so a changed byte anywhere, even one
the zip's CRC-32 or zlib would let through, is found. Version 1 (simroad 0.1.0) has
no checksum and is still read, with every check below but that one.

==================  ========  ==============================  =================================
array               dtype     shape                           values
==================  ========  ==============================  =================================
support_vectors     float64   (n_sv, 3), n_sv >= 1            finite
dual_coef           float64   (n_sv,)                         finite
intercept           float64   ()                              finite
gamma               float64   ()                              finite, > 0
feature_mean        float64   (3,)                            finite
feature_scale       float64   (3,)                            finite, > 0
lut_bits            int64     ()                              5, 6 or 7 (= params lut_bits)
lut                 uint8     (2**(3 bits) / 8,)              bit-packed coarse table
lut_refined_cells   int32     (n,)                            the coarse table's boundary cells
lut_fine            uint8     (n * 2**(3 (8 - bits)) / 8,)    bit-packed fine table
meta                str       ()                              JSON: format, version, params
checksum            str       ()                              versions 2 and 3
==================  ========  ==============================  =================================
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from simroad.core.validation import check_bool, check_choice, check_in_range, check_int_in_range
from simroad.detector._strict_npz import model_error, read_npz
from simroad.detector.features import N_FEATURES
from simroad.detector.lut import ColourTable
from simroad.detector.reference import NORMALIZATIONS
from simroad.detector.svm import KernelExpansion
from simroad.errors import InvalidParameterError, SimroadError
from simroad.filters.pipeline import FILTER_VARIANTS, FILTERS

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "PARAM_NAMES",
    "READABLE_VERSIONS",
    "StoredModel",
    "array_checksum",
    "check_model_destination",
    "check_params",
    "parse_model",
    "read_arrays",
    "read_model",
    "write_model",
]

FORMAT = "simroad.RoadDetector"
#: Version written by :func:`write_model`.
FORMAT_VERSION = 3
#: Versions :func:`parse_model` reads (1: no checksum; 1 and 2: no ``normalize``
#: parameter, read as ``"none"``).
READABLE_VERSIONS = (1, 2, 3)
_CHECKSUM = "checksum"
_ARRAYS_V1 = frozenset({"support_vectors", "dual_coef", "intercept", "gamma", "feature_mean", "feature_scale", "meta",
                        "lut", "lut_bits", "lut_refined_cells", "lut_fine"})  # fmt: skip
_ARRAYS_V2 = _ARRAYS_V1 | {_CHECKSUM}
_ARRAYS = {1: _ARRAYS_V1, 2: _ARRAYS_V2, 3: _ARRAYS_V2}  # 3 differs from 2 in its parameters only
#: The constructor parameters of :class:`~simroad.detector.RoadDetector`, all stored in a model file.
PARAM_NAMES = frozenset({"filters", "filter_variant", "morphology", "C", "gamma", "max_samples", "nonroad_weight",
                         "lut_bits", "random_state", "normalize"})  # fmt: skip


@dataclass(frozen=True)
class StoredModel:
    """The content of a model file: constructor parameters and fitted state."""

    params: dict[str, Any]
    feature_mean: np.ndarray
    feature_scale: np.ndarray
    svm: KernelExpansion
    lut: ColourTable


def check_model_destination(path: object, *, name: str = "path", make_parents: bool = False) -> Path:
    """Check, before any work, that a model file can be written at ``path``; return it as a Path.

    Refused, with a :class:`~simroad.SimroadError` naming ``name``: a value that is not a
    path, an existing directory, a path below a regular file, a missing folder (unless
    ``make_parents``, which creates it), a folder that is not writable, an existing
    file that is not writable.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.npz`` file to write.
    name : str, optional
        The parameter or flag named in errors (e.g. ``"out"`` for ``--out``).
    make_parents : bool, optional
        Create missing folders (as ``mkdir -p``) instead of refusing them.
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InvalidParameterError(
            f"{name}: expected a file path (str or os.PathLike), got {type(path).__name__} {path!r}."
        )
    p = Path(path)
    try:
        if p.is_dir():
            raise InvalidParameterError(
                f"{name}: {str(p)!r} is a directory; give a file path such as {str(p / 'road_detector.npz')!r}."
            )
        parent = p.parent
        existing = parent
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        if not existing.is_dir():
            raise InvalidParameterError(
                f"{name}: cannot write {str(p)!r}: {str(existing)!r} is a file, not a folder. Choose another path."
            )
        if existing != parent:
            if not make_parents:
                raise InvalidParameterError(
                    f"{name}: the folder {str(parent)!r} does not exist. Create it first (mkdir -p {parent}) "
                    "or choose an existing folder."
                )
            parent.mkdir(parents=True, exist_ok=True)
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InvalidParameterError(f"{name}: the folder {str(parent)!r} is not writable. Choose another path.")
        if p.exists() and (not p.is_file() or not os.access(p, os.W_OK)):
            raise InvalidParameterError(f"{name}: {str(p)!r} exists and is not a writable file. Choose another path.")
    except OSError as exc:
        raise InvalidParameterError(
            f"{name}: cannot write {str(p)!r} ({exc.strerror or exc}). Choose another path."
        ) from None
    return p


def check_params(params: object) -> None:
    """Check stored detector parameters: exactly :data:`PARAM_NAMES`, each valid as ``RoadDetector.fit`` wants it.

    Raises :class:`~simroad.SimroadError` naming the parameter; values are not changed.
    """

    if not isinstance(params, dict):
        raise InvalidParameterError(
            f"params: expected a mapping of parameter names to values, got {type(params).__name__}."
        )
    missing, unknown = sorted(PARAM_NAMES - set(params)), sorted(set(params) - PARAM_NAMES)
    if missing or unknown:
        raise InvalidParameterError(
            f"params: expected exactly {sorted(PARAM_NAMES)}; missing {missing}, unknown {unknown}."
        )
    filters = params["filters"]
    if isinstance(filters, str) or not isinstance(filters, (list, tuple)):
        raise InvalidParameterError(f"filters: expected a list of filter names, got {filters!r}.")
    for f in filters:
        check_choice("filters", f, FILTERS)
    check_choice("filter_variant", params["filter_variant"], FILTER_VARIANTS)
    check_choice("normalize", params["normalize"], NORMALIZATIONS)
    check_bool("morphology", params["morphology"])
    check_in_range("C", params["C"], 0.0, 1e6, low_inclusive=False)
    if params["gamma"] != "scale":
        check_in_range("gamma", params["gamma"], 0.0, 1e6, low_inclusive=False)
    check_int_in_range("max_samples", params["max_samples"], 2, 1_000_000)
    check_in_range("nonroad_weight", params["nonroad_weight"], 0.0, 1e3, low_inclusive=False)
    check_int_in_range("lut_bits", params["lut_bits"], 5, 7)
    check_int_in_range("random_state", params["random_state"], 0, 2**63 - 1)


def array_checksum(arrays: Mapping[str, Any]) -> str:
    """``"sha256:<hex>"`` over every array but ``checksum``, in name order: name, dtype, shape and bytes."""
    digest = hashlib.sha256()
    for key in sorted(arrays):
        if key == _CHECKSUM:
            continue
        a = np.asarray(arrays[key])
        for part in (json.dumps([key, a.dtype.str, list(a.shape)]).encode(), a.tobytes()):
            digest.update(len(part).to_bytes(8, "little"))
            digest.update(part)
    return "sha256:" + digest.hexdigest()


def write_model(
    path: str | os.PathLike,
    *,
    params: dict[str, Any],
    feature_mean: np.ndarray,
    feature_scale: np.ndarray,
    svm: KernelExpansion,
    lut: ColourTable,
) -> None:
    """Write a model to ``path`` (compressed ``.npz``, format :data:`FORMAT_VERSION`), atomically.

    The destination (:func:`check_model_destination`) and the parameters are checked
    first; the file is written under a temporary name in the same folder and renamed,
    so it is never partial. See the module docstring for the arrays.
    """
    dest = check_model_destination(path)
    check_params(params)
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "params": params,
        "features": "I, S cos H, S sin H (paper eqs. 10-12), unsmoothed",
        "n_support": len(svm.dual_coef),
        "checksum": "sha256 of every other array: name, dtype, shape, bytes; in name order",
    }
    arrays: dict[str, Any] = {
        "support_vectors": svm.support_vectors,
        "dual_coef": svm.dual_coef,
        "intercept": np.float64(svm.intercept),
        "gamma": np.float64(svm.gamma),
        "feature_mean": feature_mean,
        "feature_scale": feature_scale,
        "meta": np.array(json.dumps(meta)),
        **lut.to_arrays(),
    }
    arrays[_CHECKSUM] = np.array(array_checksum(arrays))
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        os.replace(tmp, dest)
    except OSError as exc:
        raise InvalidParameterError(f"path: could not write {str(dest)!r} ({exc.strerror or exc}).") from None
    finally:
        tmp.unlink(missing_ok=True)


def read_arrays(path: object) -> dict[str, np.ndarray]:
    """Every array of the model ``.npz`` at ``path``, read strictly (see :func:`simroad.detector._strict_npz.read_npz`)."""
    return read_npz(path)


def read_model(path: object) -> StoredModel:
    """Read and check the model file at ``path``; one :class:`~simroad.SimroadError` if it is not whole."""
    return parse_model(read_npz(path), str(path))


def _array(arrays: Mapping[str, np.ndarray], key: str, shape: tuple[int | None, ...], *, positive: bool = False):
    """The float64 array ``key`` of the given shape (None: any length), finite (and > 0)."""
    a = arrays[key]
    ok = a.dtype == np.float64 and a.ndim == len(shape) and all(n is None or n == m for n, m in zip(shape, a.shape))
    if not ok:
        want = "(" + ", ".join("n" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"array {key!r} is {a.dtype} {a.shape}; the format needs float64 {want}")
    if not np.isfinite(a).all():
        raise ValueError(f"array {key!r} holds NaN or infinite values")
    if positive and not (a > 0).all():
        raise ValueError(f"array {key!r} must be > 0, got {a.tolist()}")
    return a


def _meta(arrays: Mapping[str, np.ndarray]) -> dict[str, Any]:
    raw = arrays["meta"]
    if raw.dtype.kind != "U" or raw.shape != ():
        raise ValueError(f"array 'meta' is {raw.dtype} {raw.shape}; the format needs one JSON string")
    meta = json.loads(str(raw))
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ValueError(f"array 'meta' does not describe a {FORMAT} (format {meta.get('format')!r})"
                         if isinstance(meta, dict) else "array 'meta' is not a JSON object")  # fmt: skip
    version = meta.get("version")
    if isinstance(version, bool) or version not in READABLE_VERSIONS:
        raise ValueError(f"format version {version!r}; this simroad reads versions {READABLE_VERSIONS}")
    if not isinstance(meta.get("params"), dict):
        raise ValueError("array 'meta' has no 'params' object")
    return meta


def _check_names(arrays: Mapping[str, np.ndarray], version: int) -> None:
    missing = sorted(_ARRAYS[version] - set(arrays))
    unexpected = sorted(set(arrays) - _ARRAYS[version])
    if missing or unexpected:
        raise ValueError(f"format version {version} needs arrays {sorted(_ARRAYS[version])}; "
                         f"missing {missing}, unexpected {unexpected}")  # fmt: skip


def parse_model(arrays: dict[str, np.ndarray], where: str) -> StoredModel:
    """Check and decode the arrays of a model file; ``where`` names it in errors.

    Checks, in order: the array names, ``meta`` (format, version), the checksum
    (version 2), the parameters, and every array's dtype, shape and values against
    the format (module docstring). The stored ``filters`` parameter (a JSON list)
    comes back as a tuple, as the estimator holds it.
    """
    try:
        if "meta" not in arrays:
            raise ValueError(f"missing array 'meta'; arrays present: {sorted(arrays)}")
        meta = _meta(arrays)
        _check_names(arrays, meta["version"])
        if meta["version"] >= 2:
            stored = arrays[_CHECKSUM]
            if stored.dtype.kind != "U" or stored.shape != () or str(stored) != array_checksum(arrays):
                raise ValueError(
                    "checksum mismatch: the arrays are not the ones that were saved (file modified or damaged)"
                )
        params = dict(meta["params"])
        if meta["version"] < 3:
            params.setdefault("normalize", "none")  # before the parameter existed
        try:
            check_params(params)
        except SimroadError as exc:
            raise ValueError(f"stored {exc}") from None
        params["filters"] = tuple(params["filters"])
        sv = _array(arrays, "support_vectors", (None, N_FEATURES))
        if len(sv) < 1 or meta.get("n_support", len(sv)) != len(sv):
            raise ValueError(f"array 'support_vectors' has {len(sv)} rows; meta says {meta.get('n_support')}")
        svm = KernelExpansion(
            sv, _array(arrays, "dual_coef", (len(sv),)), float(_array(arrays, "intercept", ())),
            float(_array(arrays, "gamma", (), positive=True)),
        )  # fmt: skip
        mean = _array(arrays, "feature_mean", (N_FEATURES,))
        scale = _array(arrays, "feature_scale", (N_FEATURES,), positive=True)
        lut = ColourTable.from_arrays(arrays)
        if lut.bits != params["lut_bits"]:
            raise ValueError(f"array 'lut_bits' is {lut.bits} but parameter lut_bits is {params['lut_bits']}")
    except (ValueError, TypeError, KeyError, AttributeError) as exc:  # SimroadError is a ValueError
        raise model_error(where, str(exc)) from None
    return StoredModel(params, mean, scale, svm, lut)
