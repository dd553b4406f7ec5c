"""Input checks that fail with a message naming the parameter, what was expected,
what came, and how to fix it.

Every public entry point of simroad validates its arguments through these helpers,
so users never see a deep traceback from NumPy or OpenCV.
"""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from simroad.errors import InvalidParameterError

__all__ = [
    "IMAGE_DTYPES",
    "check_array",
    "check_bool",
    "check_choice",
    "check_fields_in_range",
    "check_finite_number",
    "check_image",
    "check_in_range",
    "check_int_in_range",
    "check_mask",
    "normalize_rng",
]


#: The dtypes an RGB frame may have: uint8 in 0..255, or float in [0, 1].
IMAGE_DTYPES = ("uint8", "float32", "float64")


def _did_you_mean(value: str, valid: Iterable[str]) -> str:
    close = difflib.get_close_matches(str(value), list(valid), n=1, cutoff=0.5)
    return f" Did you mean {close[0]!r}?" if close else ""


def check_choice(name: str, value: Any, valid: Iterable[str]) -> str:
    """Return ``value`` if it is one of ``valid``, else raise listing the valid ones.

    >>> check_choice("scenario", "racetrack", ["racetrack", "highway"])
    'racetrack'
    """
    valid = list(valid)
    if not isinstance(value, str) or value not in valid:
        hint = _did_you_mean(value, valid) if isinstance(value, str) else ""
        raise InvalidParameterError(
            f"{name}: unknown value {value!r}; expected one of {', '.join(repr(v) for v in valid)}.{hint}"
        )
    return value


def check_bool(name: str, value: Any) -> bool:
    """Check a plain True/False flag (numpy bools accepted) and return it."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidParameterError(f"{name}: expected True or False, got {value!r} ({type(value).__name__}).")
    return bool(value)


def check_finite_number(name: str, value: Any) -> float:
    """Return ``value`` as a float, raising if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidParameterError(f"{name}: expected a number, got {type(value).__name__} {value!r}.")
    value = float(value)
    if not math.isfinite(value):
        raise InvalidParameterError(f"{name}: expected a finite number, got {value!r}.")
    return value


def check_in_range(
    name: str,
    value: Any,
    low: float,
    high: float,
    *,
    unit: str = "",
    low_inclusive: bool = True,
    high_inclusive: bool = True,
) -> float:
    """Return ``value`` as a float if it lies in the interval, else raise naming it.

    >>> check_in_range("severity", 0.5, 0.0, 1.0)
    0.5
    """
    value = check_finite_number(name, value)
    ok_low = value >= low if low_inclusive else value > low
    ok_high = value <= high if high_inclusive else value < high
    if not (ok_low and ok_high):
        lb = "[" if low_inclusive else "("
        hb = "]" if high_inclusive else ")"
        u = f" {unit}" if unit else ""
        raise InvalidParameterError(
            f"{name}: expected a value in {lb}{low:g}, {high:g}{hb}{u}, got {value:g}{u}. "
            f"Pass a value inside that range."
        )
    return value


def check_fields_in_range(
    obj: Any, ranges: Mapping[str, tuple[float, float, str, bool]], *, high_exclusive: Iterable[str] = ()
) -> dict[str, float]:
    """Check the numeric fields of a config against its table of valid ranges.

    Parameters
    ----------
    obj : object
        The config (a dataclass instance); its attributes are read, not changed.
    ranges : mapping
        Field name -> ``(low, high, unit, low_inclusive)``, checked in this order with
        :func:`check_in_range` (``high`` included unless the name is in
        ``high_exclusive``), so the first bad field is the one reported.
    high_exclusive : iterable of str
        The fields whose ``high`` itself is not valid.

    Returns
    -------
    dict of str to float
        Field name -> its value as a float.
    """
    open_high = set(high_exclusive)
    return {
        name: check_in_range(
            name,
            getattr(obj, name),
            low,
            high,
            unit=unit,
            low_inclusive=low_inclusive,
            high_inclusive=name not in open_high,
        )
        for name, (low, high, unit, low_inclusive) in ranges.items()
    }


def check_int_in_range(name: str, value: Any, low: int, high: int) -> int:
    """Return ``value`` as an int in ``[low, high]``, else raise naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise InvalidParameterError(
                f"{name}: expected an integer in [{low}, {high}], got {type(value).__name__} {value!r}."
            )
    value = int(value)
    if not low <= value <= high:
        raise InvalidParameterError(
            f"{name}: expected an integer in [{low}, {high}], got {value}. Pass a value inside that range."
        )
    return value


def _check_ndarray(name: str, value: Any, dtype: str | Sequence[str], hint: str) -> None:
    """The type and dtype checks shared by :func:`check_image` and :func:`check_array`."""
    if not isinstance(value, np.ndarray):
        raise InvalidParameterError(
            f"{name}: expected a numpy array, got {type(value).__name__}. Convert it with numpy.asarray(...)."
        )
    dtypes = (dtype,) if isinstance(dtype, str) else tuple(dtype)
    if value.dtype.name not in dtypes:
        raise InvalidParameterError(f"{name}: expected dtype {' or '.join(dtypes)}, got {value.dtype}. {hint}")


def check_image(
    name: str,
    image: Any,
    *,
    dtype: str | tuple[str, ...] = ("uint8", "float32", "float64"),
    channels: int | None = 3,
    min_size: int = 1,
) -> np.ndarray:
    """Check an image array and return it (as an ndarray, not copied).

    Parameters
    ----------
    name : str
        The parameter name used in error messages.
    image : array_like
        ``(H, W, C)`` when ``channels`` is given, ``(H, W)`` when ``channels=None``
        is meant to accept single-channel images only (``channels=0``) … see below.
    dtype : str or tuple of str
        Accepted dtypes. Float images must be finite and lie in [0, 1].
    channels : int or None
        Required number of channels; ``0`` means a 2-D (H, W) image; ``None``
        accepts either (H, W) or (H, W, C).
    min_size : int
        Minimum height and width in pixels.
    """
    _check_ndarray(
        name,
        image,
        dtype,
        "Convert with image.astype(np.uint8) (values 0-255) or image.astype(np.float32) / 255 (values in [0, 1]).",
    )
    if channels == 0:
        shape_ok = image.ndim == 2
        expected = "(H, W)"
    elif channels is None:
        shape_ok = image.ndim == 2 or image.ndim == 3
        expected = "(H, W) or (H, W, C)"
    else:
        shape_ok = image.ndim == 3 and image.shape[2] == channels
        expected = f"(H, W, {channels})"
    if not shape_ok:
        raise InvalidParameterError(f"{name}: expected an array of shape {expected}, got shape {image.shape}.")
    h, w = image.shape[:2]
    if h < min_size or w < min_size:
        raise InvalidParameterError(
            f"{name}: expected at least {min_size}x{min_size} pixels, got {w}x{h} (width x height)."
        )
    if image.dtype.kind == "f":
        _check_finite(name, image)
        lo, hi = float(image.min()), float(image.max())
        if lo < 0.0 or hi > 1.0:
            raise InvalidParameterError(
                f"{name}: float images must lie in [0, 1], got values in [{lo:g}, {hi:g}]. Divide uint8 images by 255."
            )
    return image


def _check_finite(name: str, array: np.ndarray) -> None:
    """Raise naming ``name`` if the float ``array`` holds NaN or infinite values."""
    finite = np.isfinite(array)
    if not finite.all():
        bad = int(array.size - np.count_nonzero(finite))
        raise InvalidParameterError(
            f"{name}: expected finite values, got {bad} NaN or infinite value(s). "
            "Replace them first, e.g. with numpy.nan_to_num(...)."
        )


def check_array(
    name: str,
    array: Any,
    *,
    dtype: str | tuple[str, ...] = ("float32", "float64"),
    ndim: int | tuple[int, ...] = (1, 2, 3),
) -> np.ndarray:
    """Check a non-empty numeric array of given dtypes and dimensions, finite if float; return it (not copied).

    Unlike :func:`check_image` the values may lie anywhere (no [0, 1] range), so
    this suits intermediate quantities such as box-filter inputs or SVM support
    vectors.

    Parameters
    ----------
    name : str
        The parameter name used in error messages.
    array : ndarray
        The array to check; lists are refused (convert with ``numpy.asarray``).
    dtype : str or tuple of str
        Accepted dtype names.
    ndim : int or tuple of int
        Accepted numbers of dimensions.
    """
    dtypes = (dtype,) if isinstance(dtype, str) else tuple(dtype)
    _check_ndarray(name, array, dtypes, f"Convert with .astype(np.{dtypes[0]}).")
    dims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    if array.ndim not in dims:
        raise InvalidParameterError(
            f"{name}: expected an array with {' or '.join(str(d) for d in dims)} dimensions, got shape {array.shape}."
        )
    if array.size == 0:
        raise InvalidParameterError(f"{name}: expected a non-empty array, got shape {array.shape}.")
    if array.dtype.kind == "f":
        _check_finite(name, array)
    return array


def check_mask(name: str, mask: Any, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Check a boolean (H, W) mask, optionally of a given shape, and return it."""
    if not isinstance(mask, np.ndarray):
        raise InvalidParameterError(f"{name}: expected a numpy bool array, got {type(mask).__name__}.")
    if mask.dtype != bool:
        if mask.dtype.kind in "iu" and mask.size and set(np.unique(mask)).issubset({0, 1}):
            mask = mask.astype(bool)
        else:
            raise InvalidParameterError(
                f"{name}: expected a bool (H, W) mask, got dtype {mask.dtype}. Convert with mask > 0."
            )
    if mask.ndim != 2:
        raise InvalidParameterError(f"{name}: expected a 2-D (H, W) mask, got shape {mask.shape}.")
    if mask.size == 0:
        raise InvalidParameterError(f"{name}: expected a mask of at least 1x1 pixels, got shape {mask.shape}.")
    if shape is not None and mask.shape != tuple(shape):
        raise InvalidParameterError(f"{name}: expected shape {tuple(shape)} to match the image, got {mask.shape}.")
    return mask


def normalize_rng(rng: np.random.Generator | int | None, *, name: str = "rng") -> np.random.Generator:
    """Return a Generator from a Generator or an integer seed.

    ``None`` is refused on purpose: every random draw in simroad must be seeded.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        if rng < 0:
            raise InvalidParameterError(
                f"{name}: expected a seed >= 0, got {int(rng)}. Pass a non-negative integer seed."
            )
        return np.random.default_rng(int(rng))
    raise InvalidParameterError(
        f"{name}: expected a numpy Generator or an integer seed, got {rng!r}. Pass rng=np.random.default_rng(seed)."
    )


# --- output paths: checked before any work, nothing created -------------------------


def _nearest_existing(p: Path) -> Path:
    """The path itself or its closest ancestor that exists."""
    for candidate in (p, *p.parents):
        if candidate.exists() or candidate.is_symlink():
            return candidate
    return Path(p.anchor)


def check_output_dir(name: str, path: Any) -> Path:
    """Check that ``path`` is, or can be created as, a writable directory; return a Path.

    Nothing is created: the first existing ancestor must be a writable directory
    (not a regular file, which would make every folder below it impossible).
    """
    if not isinstance(path, (str, os.PathLike)) or str(path).strip() == "":
        raise InvalidParameterError(f"{name}: expected a directory path, got {type(path).__name__} {path!r}.")
    p = Path(path)
    base = _nearest_existing(p)
    if base == p and not p.is_dir():
        raise InvalidParameterError(f"{name}: {str(p)!r} is a file, not a directory. Choose a writable directory path.")
    if not base.is_dir():
        raise InvalidParameterError(
            f"{name}: {str(p)!r} lies below {str(base)!r}, which is a file, not a directory. Choose a writable path."
        )
    if not os.access(base, os.W_OK | os.X_OK):
        raise InvalidParameterError(
            f"{name}: {str(base)!r} is not writable, so {str(p)!r} cannot be written. Choose another path."
        )
    return p


def ensure_writable_dir(name: str, path: str | os.PathLike) -> Path:
    """Create ``path`` if needed and check it is a writable directory."""
    p = check_output_dir(name, path)  # a path (not 5 or ''), not a file nor below one
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InvalidParameterError(
            f"{name}: cannot create directory {str(p)!r} ({exc.strerror}). Choose a writable path."
        ) from None
    if not p.is_dir() or not os.access(p, os.W_OK):
        raise InvalidParameterError(f"{name}: {str(p)!r} is not a writable directory. Choose a writable path.")
    return p


def check_output_file(name: str, path: Any, *, suffixes: Iterable[str] | None = None) -> Path:
    """Check that a file can be written at ``path`` (its folder may still be missing); return a Path.

    ``suffixes`` (lower case, with the dot) restricts the file name's extension.
    Nothing is created.
    """
    if not isinstance(path, (str, os.PathLike)) or str(path).strip() == "":
        raise InvalidParameterError(f"{name}: expected a file path, got {type(path).__name__} {path!r}.")
    p = Path(path)
    if p.is_dir():
        raise InvalidParameterError(f"{name}: {str(p)!r} is a directory; give a file path inside it.")
    if suffixes is not None:
        valid = sorted(set(suffixes))
        if p.suffix.lower() not in valid:
            raise InvalidParameterError(
                f"{name}: cannot write {str(p)!r}: the file type {p.suffix or '(none)'!r} is not supported; "
                f"expected a name ending in one of {', '.join(valid)}."
            )
    check_output_dir(name, p.parent)
    if p.exists() and not os.access(p, os.W_OK):
        raise InvalidParameterError(f"{name}: {str(p)!r} exists and is not writable. Choose another path.")
    return p


def _check_input_path(name: str, path: Any, kind: str) -> Path:
    """``path`` as a Path naming an existing ``kind`` (``"directory"`` or ``"file"``)."""
    if not isinstance(path, (str, os.PathLike)) or str(path).strip() == "":
        raise InvalidParameterError(f"{name}: expected a {kind} path, got {type(path).__name__} {path!r}.")
    p = Path(path)
    if not p.exists():
        raise InvalidParameterError(f"{name}: {str(p)!r} does not exist; expected an existing {kind}.")
    if not (p.is_dir() if kind == "directory" else p.is_file()):
        what = "a directory" if kind == "directory" else "a regular file (a directory?)"
        raise InvalidParameterError(f"{name}: {str(p)!r} is not {what}; expected an existing {kind}.")
    return p


def check_input_dir(name: str, path: Any) -> Path:
    """Check that ``path`` names an existing directory; return a Path."""
    return _check_input_path(name, path, "directory")


def check_input_file(name: str, path: Any) -> Path:
    """Check that ``path`` names an existing, readable regular file; return a Path."""
    p = _check_input_path(name, path, "file")
    if not os.access(p, os.R_OK):
        raise InvalidParameterError(f"{name}: {str(p)!r} is not readable; check its permissions.")
    return p


__all__ += ["check_input_dir", "check_input_file", "check_output_dir", "check_output_file", "ensure_writable_dir"]
