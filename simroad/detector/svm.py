"""The SVM's decision function as plain arrays (paper eq. 30), for storage without pickle.

``F(x) = sign( sum_i y_i lambda_i K(x, x_i) + b )`` with the RBF kernel
``K(x, x') = exp(-gamma |x - x'|^2)``: support vectors ``x_i``, signed multipliers
``y_i lambda_i`` (scikit-learn's ``dual_coef_``) and the bias ``b`` fully define a
trained :class:`sklearn.svm.SVC`. A loaded model evaluates this expansion directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.metrics.pairwise import rbf_kernel

from simroad.core.validation import check_array, check_finite_number
from simroad.errors import InvalidParameterError

__all__ = ["KernelExpansion"]

_CHUNK = 16384
_FLOATS = ("float32", "float64")


@dataclass(frozen=True)
class KernelExpansion:
    """A binary RBF SVM as arrays (eq. 30).

    Attributes
    ----------
    support_vectors : ndarray, float64, (n_sv, n_features)
    dual_coef : ndarray, float64, (n_sv,)
        ``y_i lambda_i``; positive for the class "road" (label 1).
    intercept : float
        ``b``.
    gamma : float
        RBF kernel width, in squared inverse feature units.
    """

    support_vectors: np.ndarray
    dual_coef: np.ndarray
    intercept: float
    gamma: float

    def __post_init__(self) -> None:
        # Checked here, so a damaged model or a hand-made expansion fails at once, naming
        # the field, instead of later in predict() with a broadcast error.
        sv = check_array("support_vectors", self.support_vectors, dtype=_FLOATS, ndim=2)
        coef = check_array("dual_coef", self.dual_coef, dtype=_FLOATS, ndim=1)
        if len(coef) != len(sv):
            raise InvalidParameterError(
                f"dual_coef: expected one coefficient per support vector ({len(sv)}), got shape {coef.shape}."
            )
        intercept = check_finite_number("intercept", self.intercept)
        gamma = check_finite_number("gamma", self.gamma)
        if gamma <= 0.0:
            raise InvalidParameterError(f"gamma: expected an RBF kernel width > 0, got {gamma:g}.")
        object.__setattr__(self, "support_vectors", np.asarray(sv, dtype=np.float64))
        object.__setattr__(self, "dual_coef", np.asarray(coef, dtype=np.float64))
        object.__setattr__(self, "intercept", intercept)
        object.__setattr__(self, "gamma", gamma)

    @classmethod
    def from_svc(cls, svc) -> KernelExpansion:
        """Extract the expansion of a fitted binary ``SVC(kernel="rbf", gamma=<float>)``
        whose classes are ``[0, 1]``."""
        return cls(
            np.asarray(svc.support_vectors_, dtype=np.float64),
            np.asarray(svc.dual_coef_, dtype=np.float64).ravel(),
            float(svc.intercept_[0]),
            float(svc.gamma),
        )

    def decision_function(self, x: np.ndarray) -> np.ndarray:
        """``sum_i y_i lambda_i K(x, x_i) + b`` for rows of ``x`` (N, n_features); (N,) float64."""
        x = np.asarray(x, dtype=np.float64)
        n_features = self.support_vectors.shape[1]
        if x.ndim != 2 or x.shape[1] != n_features:
            raise InvalidParameterError(
                f"x: expected rows of {n_features} features, shape (N, {n_features}); got {x.shape}."
            )
        if not np.isfinite(x).all():
            raise InvalidParameterError("x: expected finite feature values, got NaN or infinite ones.")
        out = np.empty(len(x))
        for s in range(0, len(x), _CHUNK):
            k = rbf_kernel(x[s : s + _CHUNK], self.support_vectors, gamma=self.gamma)
            out[s : s + _CHUNK] = k @ self.dual_coef + self.intercept
        return out

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Road (True) where the decision function is positive (eq. 30); (N,) bool."""
        return self.decision_function(x) > 0.0
