"""Mask metrics (paper eqs. 32-33): confusion counts, error rates and a pooled score.

Conventions: a rate whose denominator is zero (e.g. FNR of a frame without road) is
``nan``. ``valid`` restricts the count to some pixels, e.g. the ground below the
horizon; without it every pixel counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simroad.core.validation import check_int_in_range, check_mask
from simroad.errors import InvalidParameterError

__all__ = ["MaskScore", "confusion", "error_rates", "rates_from_counts"]

_RATE_KEYS = ("fnr", "fpr", "precision", "recall", "f1", "iou")


def _ratio(num: int, den: int) -> float:
    return num / den if den else math.nan


def confusion(pred: np.ndarray, gt: np.ndarray, valid: np.ndarray | None = None) -> dict[str, int]:
    """Pixel counts of a predicted road mask against the ground truth.

    Parameters
    ----------
    pred, gt : ndarray, bool, (H, W)
        Predicted and true road masks (0/1 integer masks are accepted).
    valid : ndarray, bool, (H, W), optional
        Pixels to count; all when None.

    Returns
    -------
    dict
        ``tp`` (road called road), ``fp`` (non-road called road), ``fn`` (road called
        non-road), ``tn`` (non-road called non-road), as Python ints.
    """
    gt = check_mask("gt", gt)
    pred = check_mask("pred", pred, shape=gt.shape)
    if valid is not None:
        valid = check_mask("valid", valid, shape=gt.shape)
        pred, gt = pred[valid], gt[valid]
    n = int(gt.size)
    tp = int(np.count_nonzero(pred & gt))
    n_pred, n_gt = int(np.count_nonzero(pred)), int(np.count_nonzero(gt))
    fp, fn = n_pred - tp, n_gt - tp
    return {"tp": tp, "fp": fp, "fn": fn, "tn": n - tp - fp - fn}


def rates_from_counts(tp: int, fp: int, fn: int, tn: int) -> dict[str, float]:
    """FNR (eq. 32), FPR (eq. 33), precision, recall, F1 and IoU from counts.

    ``FNR = FN / (TP + FN)``, ``FPR = FP / (FP + TN)``, ``precision = TP / (TP + FP)``,
    ``recall = 1 - FNR``, ``F1 = 2 TP / (2 TP + FP + FN)``, ``IoU = TP / (TP + FP + FN)``;
    ``nan`` where a denominator is 0.
    """
    for name, count in (("tp", tp), ("fp", fp), ("fn", fn), ("tn", tn)):
        check_int_in_range(name, count, 0, 2**62)
    return {
        "fnr": _ratio(fn, tp + fn),
        "fpr": _ratio(fp, fp + tn),
        "precision": _ratio(tp, tp + fp),
        "recall": _ratio(tp, tp + fn),
        "f1": _ratio(2 * tp, 2 * tp + fp + fn),
        "iou": _ratio(tp, tp + fp + fn),
    }


def error_rates(pred: np.ndarray, gt: np.ndarray, valid: np.ndarray | None = None) -> dict[str, float]:
    """False negative and false positive rates of a road mask (paper eqs. 32-33).

    Parameters
    ----------
    pred, gt : ndarray, bool, (H, W)
    valid : ndarray, bool, (H, W), optional

    Returns
    -------
    dict
        ``{"fnr", "fpr"}``, as :func:`confusion` and :func:`rates_from_counts` return
        dicts: ``fnr = FN / (TP + FN)``, the share of road pixels missed (nan without
        road pixels); ``fpr = FP / (FP + TN)``, the share of non-road pixels called
        road (nan without any).
    """
    c = confusion(pred, gt, valid)
    return {"fnr": _ratio(c["fn"], c["tp"] + c["fn"]), "fpr": _ratio(c["fp"], c["fp"] + c["tn"])}


def _nanmean(values: list[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return sum(finite) / len(finite) if finite else math.nan


@dataclass
class MaskScore:
    """Accumulates mask metrics over many frames, pooled and per frame.

    Pooled rates (KITTI style) come from the summed counts of all frames; the
    per-frame means average each frame's own rate over the frames where it is
    defined.

    Examples
    --------
    >>> import numpy as np
    >>> score = MaskScore()
    >>> gt = np.array([[1, 1], [0, 0]], bool)
    >>> score.update(np.array([[1, 0], [1, 0]], bool), gt)["fnr"]
    0.5
    >>> score.summary()["fpr"]
    0.5
    """

    tp: int = 0
    fp: int = 0
    fn: int = 0
    tn: int = 0
    frames: list[dict[str, float]] = field(default_factory=list)

    @property
    def n_frames(self) -> int:
        """Number of frames accumulated."""
        return len(self.frames)

    def update(self, pred: np.ndarray, gt: np.ndarray, valid: np.ndarray | None = None) -> dict[str, float]:
        """Add one frame; returns its own counts and rates (see :func:`rates_from_counts`)."""
        c = confusion(pred, gt, valid)
        self.tp += c["tp"]
        self.fp += c["fp"]
        self.fn += c["fn"]
        self.tn += c["tn"]
        record = {**c, **rates_from_counts(**c)}
        self.frames.append(record)
        return dict(record)

    def merge(self, other: MaskScore) -> MaskScore:
        """A new score holding the frames of ``self`` followed by those of ``other``."""
        if not isinstance(other, MaskScore):
            raise InvalidParameterError(f"other: expected a MaskScore, got {type(other).__name__}.")
        return MaskScore(
            self.tp + other.tp,
            self.fp + other.fp,
            self.fn + other.fn,
            self.tn + other.tn,
            [dict(f) for f in self.frames + other.frames],
        )

    def pooled(self) -> dict[str, float]:
        """Rates from the counts summed over all frames."""
        return rates_from_counts(self.tp, self.fp, self.fn, self.tn)

    def per_frame_mean(self) -> dict[str, float]:
        """Mean over frames of each frame's rate (frames where it is nan are skipped)."""
        return {k: _nanmean([f[k] for f in self.frames]) for k in _RATE_KEYS}

    def summary(self) -> dict[str, float | int]:
        """Flat JSON-ready dict: ``n_frames``, the counts ``tp fp fn tn``, the pooled
        rates ``fnr fpr precision recall f1 iou`` and their per-frame means
        ``mean_fnr``, ... ``mean_iou``."""
        out: dict[str, float | int] = {"n_frames": self.n_frames}
        out.update(tp=self.tp, fp=self.fp, fn=self.fn, tn=self.tn)
        out.update(self.pooled())
        out.update({f"mean_{k}": v for k, v in self.per_frame_mean().items()})
        return out
