"""Mask metrics (paper eqs. 32-33) against counts worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simroad import SimroadError
from simroad.metrics import MaskScore, confusion, error_rates, rates_from_counts

GT = np.array(
    [[1, 1, 1, 0],
     [1, 1, 0, 0],
     [1, 0, 0, 0]], bool)  # fmt: skip
PRED = np.array(
    [[1, 1, 0, 1],
     [1, 0, 0, 0],
     [1, 1, 0, 0]], bool)  # fmt: skip
# By hand: TP = 4 ((0,0) (0,1) (1,0) (2,0)), FN = 2 ((0,2) (1,1)), FP = 2 ((0,3) (2,1)), TN = 4.


def test_confusion_and_error_rates_by_hand():
    assert confusion(PRED, GT) == {"tp": 4, "fp": 2, "fn": 2, "tn": 4}
    rates = error_rates(PRED, GT)
    fnr, fpr = rates["fnr"], rates["fpr"]
    assert set(rates) == {"fnr", "fpr"}
    assert fnr == pytest.approx(2 / 6) and fpr == pytest.approx(2 / 6)  # FN/(TP+FN), FP/(FP+TN)


def test_valid_restricts_the_count():
    valid = np.ones_like(GT)
    valid[0] = False  # drop the first row
    assert confusion(PRED, GT, valid) == {"tp": 2, "fp": 1, "fn": 1, "tn": 4}
    assert error_rates(PRED, GT, valid) == pytest.approx({"fnr": 1 / 3, "fpr": 1 / 5})


def test_rates_from_counts_and_undefined_rates():
    r = rates_from_counts(tp=4, fp=2, fn=2, tn=4)
    expect = {"fnr": 1 / 3, "fpr": 1 / 3, "precision": 2 / 3, "recall": 2 / 3, "f1": 8 / 12, "iou": 0.5}
    assert r == pytest.approx(expect)
    rates = error_rates(np.zeros((2, 2), bool), np.zeros((2, 2), bool))  # no road at all
    fnr, fpr = rates["fnr"], rates["fpr"]
    assert math.isnan(fnr) and fpr == 0.0


def test_mask_score_pools_counts_and_averages_frames():
    score = MaskScore()
    first = score.update(PRED, GT)
    assert first["fnr"] == pytest.approx(1 / 3) and first["tp"] == 4
    score.update(GT, GT)  # a perfect frame
    score.update(np.zeros_like(GT), np.zeros_like(GT))  # no road: FNR undefined for that frame
    s = score.summary()
    assert s["n_frames"] == 3 and (s["tp"], s["fp"], s["fn"], s["tn"]) == (10, 2, 2, 22)
    assert s["fnr"] == pytest.approx(2 / 12) and s["fpr"] == pytest.approx(2 / 24)  # pooled
    assert s["mean_fnr"] == pytest.approx((1 / 3 + 0) / 2)  # the nan frame is skipped
    assert s["mean_fpr"] == pytest.approx((1 / 3 + 0 + 0) / 3)
    assert set(s) >= {"precision", "recall", "f1", "iou", "mean_iou", "mean_f1", "mean_precision"}


def test_merge_equals_one_accumulation():
    a, b, both = MaskScore(), MaskScore(), MaskScore()
    a.update(PRED, GT)
    b.update(GT, GT)
    both.update(PRED, GT)
    both.update(GT, GT)
    assert a.merge(b).summary() == both.summary()
    assert a.n_frames == 1  # merge does not modify its operands


def test_empty_score_is_all_nan():
    s = MaskScore().summary()
    assert s["n_frames"] == 0 and math.isnan(s["fnr"]) and math.isnan(s["mean_fnr"])


def test_clear_errors():
    with pytest.raises(SimroadError, match=r"pred: expected shape \(3, 4\)"):
        error_rates(PRED[:2], GT)
    with pytest.raises(SimroadError, match="valid: expected shape"):
        confusion(PRED, GT, valid=np.ones((2, 2), bool))
    with pytest.raises(SimroadError, match="gt: expected a bool"):
        confusion(PRED, GT.astype(np.float32))
    with pytest.raises(SimroadError, match="other: expected a MaskScore"):
        MaskScore().merge({"tp": 1})
