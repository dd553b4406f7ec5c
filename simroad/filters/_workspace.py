"""Work arrays reused from one call to the next, one set per thread.

A filter at 1280x720 needs temporaries of several megabytes (the shadow relighting's
row sums: 8.8 MB). Allocated afresh on every frame, such an array comes from new
pages of memory, and the first touch of each page costs more than the arithmetic
done on it (about a third of a shadow frame's time). :func:`scratch` hands out the
same array again for the same name, shape and dtype, per thread (detectors may run in
several threads); its contents are whatever the last call left there.
"""

from __future__ import annotations

import threading

import numpy as np

__all__ = ["scratch"]

#: Most work arrays a thread keeps; past this, its arrays are dropped and made anew.
_MOST = 32
_LOCAL = threading.local()


def scratch(name: str, shape: tuple[int, ...], dtype: type | np.dtype) -> np.ndarray:
    """A C-contiguous array of ``shape`` and ``dtype``, uninitialised, this thread's own for ``name``.

    The caller uses it within one call and keeps no reference to it: the next call for
    the same name, shape and dtype in this thread gets the same array back.
    """
    arrays: dict | None = getattr(_LOCAL, "arrays", None)
    if arrays is None:
        arrays = _LOCAL.arrays = {}
    key = (name, shape, np.dtype(dtype))
    out = arrays.get(key)
    if out is None:
        if len(arrays) >= _MOST:
            arrays.clear()
        out = arrays[key] = np.empty(shape, dtype)
    return out
