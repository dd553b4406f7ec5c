"""How a road looks to a camera: per-frame appearance statistics and a reference.

Eight numbers per frame, computed on the 8-bit RGB frame with OpenCV's conversions
(HSV with S and V scaled to [0, 1]; CIE Lab with ``a* = a - 128`` and
``b* = b - 128``), over the pixels of the frame's road mask:

``road_V``, ``road_S``
    the median V and S of the road pixels;
``road_b``, ``road_a``
    the median b* (- blue, + yellow) and a* (- green, + red) of the road pixels;
``road_minus_surround``
    ``road_V`` minus the median V of the non-road pixels of the lower half of the
    frame (rows ``H // 2`` on); NaN when the road fills the whole lower half;
``road_spread``
    p90 - p10 of V over the road pixels;
``frame_V``
    the mean V of the whole frame;
``saturated``
    the share of pixels whose three channels are all ``>= 250``.

Frames with fewer than :data:`MIN_ROAD_PIXELS` road pixels have no statistics (the
road is out of view). The shipped reference (:func:`load_reference`) holds each
statistic's quantiles at 5 % steps over 701 CamVid road photographs (Brostow et al.
2009); :func:`ks_distance` compares a sample of per-frame values with such a table.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import cv2
import numpy as np

from simroad.core.validation import check_image, check_int_in_range, check_mask
from simroad.errors import InvalidParameterError

__all__ = [
    "MIN_ROAD_PIXELS",
    "QUANTILE_LEVELS",
    "STATISTICS",
    "AppearanceReference",
    "frame_appearance",
    "ks_distance",
    "load_reference",
    "reference_from_values",
]

#: The statistics, in the order tables list them.
STATISTICS = (
    "road_V",
    "road_S",
    "road_b",
    "road_a",
    "road_minus_surround",
    "road_spread",
    "frame_V",
    "saturated",
)
#: Frames with fewer road pixels than this have no statistics.
MIN_ROAD_PIXELS = 500
#: Levels of a reference's quantile table: 0, 0.05, ..., 1.
QUANTILE_LEVELS = tuple(k / 20 for k in range(21))
#: A channel at or above this 8-bit level counts as clipped.
SATURATION_LEVEL = 250

_SHIPPED = "road_photos_appearance.csv"


def frame_appearance(
    rgb: np.ndarray, road_mask: np.ndarray, *, min_road_pixels: int = MIN_ROAD_PIXELS
) -> dict[str, float] | None:
    """The appearance statistics of one frame (see the module's docstring).

    Parameters
    ----------
    rgb : ndarray, uint8, (H, W, 3)
        The frame, RGB order.
    road_mask : ndarray, bool, (H, W)
        Its road pixels.
    min_road_pixels : int
        Fewer road pixels than this: no statistics.

    Returns
    -------
    dict or None
        ``{statistic: value}`` for every name of :data:`STATISTICS`; None when the
        frame has fewer than ``min_road_pixels`` road pixels.
    """
    check_image("rgb", rgb, dtype="uint8")
    h, w = rgb.shape[:2]
    road = check_mask("road_mask", road_mask, shape=(h, w))
    check_int_in_range("min_road_pixels", min_road_pixels, 1, h * w)
    n_road = int(np.count_nonzero(road))
    if n_road < min_road_pixels:
        return None
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    lab = cv2.cvtColor(rgb, cv2.COLOR_RGB2LAB)
    v = hsv[..., 2]
    road_v = v[road].astype(np.float64) / 255.0
    lower = np.zeros_like(road)
    lower[h // 2 :] = True
    surround = v[lower & ~road]
    road_med = float(np.median(road_v))
    p10, p90 = np.percentile(road_v, [10.0, 90.0])
    return {
        "road_V": road_med,
        "road_S": float(np.median(hsv[..., 1][road])) / 255.0,
        "road_b": float(np.median(lab[..., 2][road])) - 128.0,
        "road_a": float(np.median(lab[..., 1][road])) - 128.0,
        "road_minus_surround": road_med - float(np.median(surround)) / 255.0 if surround.size else math.nan,
        "road_spread": float(p90 - p10),
        "frame_V": float(v.mean()) / 255.0,
        "saturated": float(np.count_nonzero((rgb >= SATURATION_LEVEL).all(axis=2))) / (h * w),
    }


@dataclass(frozen=True)
class AppearanceReference:
    """Quantile tables of the statistics over a set of real photographs.

    Attributes
    ----------
    quantiles : dict
        ``{statistic: float array (21,)}``: the values at :data:`QUANTILE_LEVELS`,
        non-decreasing.
    source : str
        Where the photographs come from (and how many).
    """

    quantiles: Mapping[str, np.ndarray]
    source: str

    def percentiles(self, statistic: str, levels: Sequence[float] = (0.1, 0.5, 0.9)) -> np.ndarray:
        """Values of ``statistic`` at ``levels`` (read off the piecewise-linear table)."""
        if statistic not in self.quantiles:
            raise InvalidParameterError(f"statistic: expected one of {', '.join(self.quantiles)}, got {statistic!r}.")
        return np.interp(np.asarray(levels, float), QUANTILE_LEVELS, self.quantiles[statistic])


def load_reference(path: str | os.PathLike | None = None) -> AppearanceReference:
    """Read a quantile table (the shipped CamVid reference when ``path`` is None).

    The file is CSV: ``#`` comment lines (the source), then a header
    ``statistic,q00,q05,...,q100`` and one row per statistic.
    """
    if path is None:
        text = resources.files("simroad.data").joinpath(_SHIPPED).read_text(encoding="utf-8")
        where = f"the shipped {_SHIPPED}"
    else:
        p = Path(path)
        if not p.is_file():
            raise InvalidParameterError(f"reference: {str(p)!r} is not a file (expected a CSV quantile table).")
        text = p.read_text(encoding="utf-8")
        where = str(p)
    comments = [line[1:].strip() for line in text.splitlines() if line.startswith("#")]
    rows = list(csv.reader(line for line in text.splitlines() if line.strip() and not line.startswith("#")))
    want = ["statistic"] + [f"q{round(q * 100):02d}" for q in QUANTILE_LEVELS]
    if not rows or [c.strip() for c in rows[0]] != want:
        raise InvalidParameterError(f"reference: {where} must start with the header {','.join(want)}.")
    table: dict[str, np.ndarray] = {}
    for row in rows[1:]:
        name = row[0].strip()
        try:
            values = np.array([float(c) for c in row[1:]])
        except ValueError as exc:
            raise InvalidParameterError(f"reference: row {name!r} of {where} has a non-number ({exc}).") from None
        if len(values) != len(QUANTILE_LEVELS) or not np.all(np.isfinite(values)) or np.any(np.diff(values) < 0):
            raise InvalidParameterError(
                f"reference: row {name!r} of {where} must hold {len(QUANTILE_LEVELS)} finite non-decreasing quantiles."
            )
        table[name] = values
    missing = [s for s in STATISTICS if s not in table]
    if missing:
        raise InvalidParameterError(f"reference: {where} lacks the statistics {', '.join(missing)}.")
    return AppearanceReference({s: table[s] for s in STATISTICS}, " ".join(comments[:3]) or where)


def reference_from_values(values: Mapping[str, Iterable[float]], source: str) -> AppearanceReference:
    """A reference from per-frame values (e.g. of the user's own photographs): each
    statistic's quantiles at :data:`QUANTILE_LEVELS` (NaNs left out)."""
    table = {}
    for s in STATISTICS:
        v = _numbers(f"values[{s!r}]", values.get(s, ()))
        v = v[np.isfinite(v)]
        if v.size == 0:
            raise InvalidParameterError(f"values: no frame has a value of {s!r}; a reference needs at least one.")
        table[s] = np.quantile(v, QUANTILE_LEVELS)
    return AppearanceReference(table, source)


def _numbers(name: str, values: Iterable[float]) -> np.ndarray:
    """``values`` as a 1-D float array, refused by ``name`` when not a flat sequence of numbers."""
    try:
        v = np.asarray(values if isinstance(values, np.ndarray) else list(values), float)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name}: expected a sequence of numbers, got {values!r:.80}.") from None
    if v.ndim != 1:
        raise InvalidParameterError(
            f"{name}: expected a flat sequence of numbers, got an array of shape {v.shape}; flatten it first."
        )
    return v


def _table_cdf(x: np.ndarray, q: np.ndarray, *, left: bool) -> np.ndarray:
    """The piecewise-linear CDF through ``(q_k, k / 20)`` at ``x``: its value (right-
    continuous) or, with ``left``, its limit from the left (the two differ where tied
    quantiles make a jump)."""
    p = np.asarray(QUANTILE_LEVELS)
    k = np.searchsorted(q, x, side="left" if left else "right") - 1  # last knot < x (left) or <= x
    inside = (k >= 0) & (k < len(q) - 1)
    kk = np.clip(k, 0, len(q) - 2)
    q0, q1 = q[kk], q[kk + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(q1 > q0, (x - q0) / (q1 - q0), 1.0)
    f = p[kk] + np.clip(t, 0.0, 1.0) * (p[kk + 1] - p[kk])
    return np.where(inside, f, np.where(k < 0, 0.0, 1.0))


def ks_distance(values: Iterable[float], quantiles: Sequence[float] | np.ndarray) -> float:
    """Kolmogorov-Smirnov distance between a sample and a quantile table.

    The table's CDF is the piecewise-linear function through ``(q_k, k / 20)``
    (a quantile table at :data:`QUANTILE_LEVELS`; tied quantiles make a jump); the
    sample's is its empirical CDF. The distance is ``sup_x |F_sample(x) - F_table(x)|``,
    found exactly: both CDFs are monotone and the table's is linear between its knots,
    so the supremum is reached at a sample value or a knot, from the left or the right.
    NaN values are left out.

    Returns
    -------
    float in [0, 1]: 0 is the same distribution, 1 no overlap.
    """
    v = _numbers("values", values)
    v = np.sort(v[np.isfinite(v)])
    q = _numbers("quantiles", quantiles)
    if v.size == 0:
        raise InvalidParameterError("values: expected at least one finite value, got none.")
    if q.shape != (len(QUANTILE_LEVELS),) or not np.all(np.isfinite(q)) or np.any(np.diff(q) < 0):
        raise InvalidParameterError(
            f"quantiles: expected {len(QUANTILE_LEVELS)} finite non-decreasing values, got {q.tolist()!r}."
        )
    x = np.unique(np.concatenate([v, q]))
    n = v.size
    f_right = np.searchsorted(v, x, side="right") / n
    f_left = np.searchsorted(v, x, side="left") / n
    d_right = np.abs(f_right - _table_cdf(x, q, left=False))
    d_left = np.abs(f_left - _table_cdf(x, q, left=True))
    return float(max(d_right.max(), d_left.max()))
