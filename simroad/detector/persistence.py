"""Road-detector model files: arrays in a compressed ``.npz`` plus a JSON header, never pickled.

A shared model file therefore cannot run code. :meth:`RoadDetector.save
<simroad.detector.RoadDetector.save>` and :meth:`~simroad.detector.RoadDetector.load`
use these functions.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from simroad._validation import SimroadError
from simroad.detector.features import N_FEATURES
from simroad.detector.lut import ColourTable
from simroad.detector.svm import KernelExpansion

__all__ = ["FORMAT", "FORMAT_VERSION", "StoredModel", "parse_model", "read_arrays", "write_model"]

FORMAT = "simroad.RoadDetector"
FORMAT_VERSION = 1
_NEEDED = frozenset({"support_vectors", "dual_coef", "intercept", "gamma", "feature_mean", "feature_scale", "meta",
                     "lut", "lut_bits", "lut_refined_cells", "lut_fine"})  # fmt: skip


@dataclass(frozen=True)
class StoredModel:
    """The content of a model file: constructor parameters and fitted state."""

    params: dict[str, Any]
    feature_mean: np.ndarray
    feature_scale: np.ndarray
    svm: KernelExpansion
    lut: ColourTable


def write_model(
    path: str | os.PathLike,
    *,
    params: dict[str, Any],
    feature_mean: np.ndarray,
    feature_scale: np.ndarray,
    svm: KernelExpansion,
    lut: ColourTable,
) -> None:
    """Write a model to ``path`` (compressed ``.npz``), atomically: a temporary name, then a rename.

    Arrays: ``support_vectors``, ``dual_coef``, ``intercept``, ``gamma``,
    ``feature_mean``, ``feature_scale``, and the lookup table (bit-packed ``lut``,
    ``lut_bits``, ``lut_refined_cells``, bit-packed ``lut_fine``); ``meta`` is a JSON
    string with the format name/version and the parameters.
    """
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "params": params,
        "features": "I, S cos H, S sin H (paper eqs. 10-12), unsmoothed",
        "n_support": len(svm.dual_coef),
    }
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
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
    with open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    os.replace(tmp, path)


def read_arrays(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` at ``path`` (pickles are refused)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except FileNotFoundError:
        raise SimroadError(
            f"path: no model file at {str(path)!r}. Train one with RoadDetector().fit(...).save(path) "
            "or `simroad train-detector`."
        ) from None
    except (OSError, ValueError) as exc:
        raise SimroadError(f"path: {str(path)!r} is not a simroad road-detector .npz file ({exc}).") from None


def parse_model(arrays: dict[str, np.ndarray], where: str) -> StoredModel:
    """Check and decode the arrays of a model file; ``where`` names it in errors.

    The stored ``filters`` parameter (a JSON list) comes back as a tuple, as the
    estimator holds it.
    """
    missing = sorted(_NEEDED - set(arrays))
    if missing:
        raise SimroadError(f"path: {where!r} is not a simroad road-detector file; missing {missing}.")
    try:
        meta = json.loads(str(arrays["meta"]))
        if meta.get("format") != FORMAT or meta.get("version") != FORMAT_VERSION:
            raise ValueError(f"format {meta.get('format')!r} version {meta.get('version')!r}")
        params = dict(meta["params"])
        if isinstance(params.get("filters"), list):
            params["filters"] = tuple(params["filters"])
        sv = np.asarray(arrays["support_vectors"], dtype=np.float64)
        coef = np.asarray(arrays["dual_coef"], dtype=np.float64).ravel()
        if sv.ndim != 2 or sv.shape[1] != N_FEATURES or len(coef) != len(sv):
            raise ValueError("inconsistent array shapes")
        lut = ColourTable.from_arrays(arrays)
        svm = KernelExpansion(sv, coef, float(arrays["intercept"]), float(arrays["gamma"]))
    except (ValueError, TypeError, KeyError) as exc:
        raise SimroadError(f"path: {where!r} holds a damaged or incompatible road-detector model ({exc}).") from None
    return StoredModel(params, arrays["feature_mean"], arrays["feature_scale"], svm, lut)
