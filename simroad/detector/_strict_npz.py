"""Strict reading of a model ``.npz``: every member CRC-checked, sizes bounded, no pickle, one clear error.

``numpy.load`` reads a damaged archive lazily and fails deep inside zipfile or zlib
(``BadZipFile``, ``zlib.error``, ``EOFError``), or not at all when a flipped byte
slips past the CRC. Here the whole archive is read at once: each member is
decompressed completely (so zipfile verifies its CRC-32), its ``.npy`` header is
parsed and its data must have exactly the size the header declares, and an object
dtype (a pickle) is refused before any byte of it is interpreted.
"""

from __future__ import annotations

import io
import math
import os
import zipfile
import zlib
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from simroad.errors import InvalidParameterError, ModelFileError, SimroadError

__all__ = ["MAX_ARRAY_BYTES", "model_error", "read_npz"]

#: Largest uncompressed member accepted (a model with a million support vectors is 24 MB).
MAX_ARRAY_BYTES = 256 << 20
_MAX_MEMBERS = 64
_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, NotImplementedError, RuntimeError, ValueError)


def model_error(where: str, what: str) -> ModelFileError:
    """The one error for a model file that is not whole: names the file, what is wrong and the fix."""
    return ModelFileError(
        f"path: {where!r} is not a simroad road-detector model, or a damaged one: {what.rstrip('.')}. Copy the file again, or train a "
        "new one with `simroad train-detector` (or RoadDetector(...).fit(images, masks).save(path))."
    )


def _source(path: object) -> tuple[Path, str]:
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InvalidParameterError(
            f"path: expected a model file path (str or os.PathLike), got {type(path).__name__} {path!r}."
        )
    p = Path(path)
    if not p.exists():
        raise ModelFileError(
            f"path: no model file at {str(p)!r}. Train one with RoadDetector().fit(...).save(path) "
            "or `simroad train-detector`."
        )
    if not p.is_file():
        raise ModelFileError(f"path: {str(p)!r} is not a file (a directory?); give the model's .npz file.")
    return p, str(path)


def _decode_npy(member: str, raw: bytes, where: str) -> np.ndarray:
    """One ``.npy`` member's bytes -> array; refuses objects and any size mismatch."""
    fp = io.BytesIO(raw)
    try:
        version = npy_format.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = npy_format.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, fortran, dtype = npy_format.read_array_header_2_0(fp)
        else:
            raise ValueError(f"unsupported .npy version {version}")
    except (ValueError, TypeError, SyntaxError, OverflowError) as exc:
        raise model_error(where, f"array {member!r} has a damaged header ({exc})") from None
    if dtype.hasobject:
        raise model_error(
            where, f"array {member!r} holds Python objects (a pickle), which simroad never loads: a model file must "
            "not be able to run code",
        )  # fmt: skip
    data = raw[fp.tell() :]
    expected = math.prod(shape) * dtype.itemsize
    if len(data) != expected:
        raise model_error(
            where, f"array {member!r} holds {len(data)} bytes of data but its header declares {dtype} {shape} "
            f"({expected} bytes): truncated or damaged",
        )  # fmt: skip
    flat = np.frombuffer(data, dtype=dtype, count=math.prod(shape))
    arr = flat.reshape(shape[::-1]).T if fortran else flat.reshape(shape)
    return np.array(arr, order="C")  # own, writable, C-ordered copy


def _members(p: Path, where: str) -> dict[str, bytes]:
    with open(p, "rb") as fh:
        head = fh.read(8)
    if not head:
        raise model_error(where, "the file is empty (0 bytes)")
    if head[:1] == b"\x80":
        raise model_error(where, "it is a Python pickle, which simroad never loads (a model file must not run code)")
    if head.startswith(b"\x93NUMPY"):
        raise model_error(where, "it is a single .npy array, not a model .npz archive")
    if not head.startswith(b"PK\x03\x04"):
        raise model_error(where, f"it is not an .npz (zip) archive (it starts with {head!r})")
    raw: dict[str, bytes] = {}
    try:
        with zipfile.ZipFile(p) as zf:
            infos = zf.infolist()
            if len(infos) > _MAX_MEMBERS:
                raise model_error(where, f"the archive holds {len(infos)} members; a model has at most a dozen")
            for info in infos:
                if not info.filename.endswith(".npy") or info.filename[:-4] in raw:
                    raise model_error(where, f"unexpected archive member {info.filename!r}")
                if info.file_size > MAX_ARRAY_BYTES:
                    raise model_error(where, f"array {info.filename!r} declares {info.file_size} bytes, too large")
                raw[info.filename[:-4]] = zf.read(info)  # reads to the end: zipfile checks the CRC-32
    except SimroadError:
        raise
    except _ZIP_ERRORS as exc:
        raise model_error(where, f"the archive is damaged or truncated ({type(exc).__name__}: {exc})") from None
    return raw


def read_npz(path: object) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` archive at ``path``, read completely and strictly.

    Raises
    ------
    SimroadError
        Naming the file and what is wrong: not a path, missing, empty, a pickle, not a
        zip, a damaged or truncated archive (zip structure, zlib stream, CRC-32), a
        member that is not an ``.npy`` array, an object array, data whose size
        differs from its header.
    """
    p, where = _source(path)
    return {name: _decode_npy(name, data, where) for name, data in _members(p, where).items()}
