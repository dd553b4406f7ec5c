"""The paper's road detector: filters -> HSI features -> SVM -> morphology (§III).

``RoadDetector`` is a scikit-learn style estimator: ``__init__`` only stores its
arguments, ``fit(images, masks)`` learns an RBF SVM on per-pixel colour features of
any RGB images with bool road masks (rendered frames or photographs), ``predict``
returns a bool road mask. Models are stored as ``.npz`` arrays plus a JSON header,
never pickled, so a shared model file cannot run code.

The filters run in one of two variants (``filter_variant``): ``"paper"`` as §III
describes them, and ``"improved"`` (default), where the rain/snow filter first undoes
the haze of the falling particles row by row (:func:`~simroad.filters.remove_haze`),
then removes the particles' excess from all channels alike and keeps lane paint
(:func:`~simroad.filters.remove_rain_snow` with ``achromatic=True, protect=5``), and the
light filter subtracts the sun's additive lobe instead of applying eq. 27
(:func:`~simroad.filters.remove_glare`). The shadow filter is the same in both.
``simroad filter-effect`` measures each against no filter on its own weather.
"""

from __future__ import annotations

import importlib.resources
import json
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.svm import SVC
from sklearn.utils.validation import check_is_fitted

from simroad._validation import (
    SimroadError,
    check_choice,
    check_image,
    check_in_range,
    check_int_in_range,
    check_mask,
    normalize_rng,
)
from simroad.detector.features import N_FEATURES, _features_f
from simroad.detector.lut import ColourTable
from simroad.detector.morphology import _ego_component, _fill_holes
from simroad.detector.svm import KernelExpansion
from simroad.filters._common import clip_planes, from_planes, planes_to_uint8, to_planes
from simroad.filters.haze import _haze_planes
from simroad.filters.light import _glare_planes, _highlights_planes
from simroad.filters.rain_snow import _rain_snow_planes
from simroad.filters.shadow import _shadows_planes

__all__ = [
    "DEFAULT_MAX_SAMPLES",
    "DEFAULT_NONROAD_WEIGHT",
    "FILTERS",
    "FILTER_VARIANTS",
    "MIN_IMAGE_SIZE",
    "RoadDetector",
    "apply_filters",
    "default_model_path",
    "train_default",
]

#: Filter names, in the order the pipeline applies them: rain and snow first (their
#: bright streaks would otherwise pass for highlights in the dark channel), then
#: highlights, then shadows (NDI needs the true value V).
FILTERS = ("rain_snow", "light", "shadow")
#: How the filters are run: ``"improved"`` (default) with the corrections that make each
#: one lower FNR + FPR on its weather, ``"paper"`` as §III describes them (see README).
FILTER_VARIANTS = ("improved", "paper")
#: Training pixels and non-road cost of the shipped model (:func:`train_default`):
#: with them the clean-frame FPR of held-out worlds fell from 3.6 % to under 2 % for
#: FNR 1.5 % -> about 2 % (README, "The shipped model").
DEFAULT_MAX_SAMPLES = 16000
DEFAULT_NONROAD_WEIGHT = 2.0
#: Smallest image side the detector accepts, in pixels.
MIN_IMAGE_SIZE = 8
_IMAGE_DTYPES = ("uint8", "float32", "float64")
_FORMAT = "simroad.RoadDetector"
_FORMAT_VERSION = 1
_NOT_FITTED = (
    "This %(name)s is not fitted yet. Call fit(images, masks) first, or get a trained "
    "one with RoadDetector.pretrained() or RoadDetector.load(path)."
)


def _check_filters(filters: object) -> tuple[str, ...]:
    """Validate a subset of :data:`FILTERS`; return it in pipeline order."""
    if isinstance(filters, str):
        filters = (filters,)
    if filters is None:
        filters = ()
    try:
        names = list(filters)
    except TypeError:
        raise SimroadError(f"filters: expected a sequence of filter names from {FILTERS}, got {filters!r}.") from None
    for name in names:
        check_choice("filters", name, FILTERS)
    return tuple(f for f in FILTERS if f in names)


def _check_variant(variant: object) -> str:
    check_choice("filter_variant", variant, FILTER_VARIANTS)
    return str(variant)


#: (filter, variant) -> the filter's core on float32 planes with the detector's settings;
#: each returns new planes (the light and shadow cores also return their masks).
_FILTER_STEPS = {
    ("rain_snow", "paper"): lambda p: _rain_snow_planes(p, 2, 1e-3, 0.02, 2),
    ("rain_snow", "improved"): lambda p: _rain_snow_planes(
        _haze_planes(p), 3, 1e-3, 0.07, 2, achromatic=True, protect=5
    ),
    ("light", "paper"): lambda p: _highlights_planes(p, 7, 8, 1e-4, 2, 0.1, 2)[0],
    ("light", "improved"): lambda p: _glare_planes(p, 3, 481, 0.01, 0.98, 0.8, 2.2)[0],
    ("shadow", "paper"): lambda p: _shadows_planes(p, -1.0, 16, 5, 0.8)[0],
    ("shadow", "improved"): lambda p: _shadows_planes(p, -1.0, 16, 5, 0.8)[0],
}


def _filter_planes(planes: list[np.ndarray], filters: tuple[str, ...], variant: str = "improved") -> list[np.ndarray]:
    """Run the filters (default settings) on float32 planes in [0, 1]; new planes in [0, 1]."""
    out = planes
    for name in filters:
        out = _FILTER_STEPS[name, variant](out)
        clip_planes(out)
    return out


def apply_filters(image: np.ndarray, filters: Sequence[str] = FILTERS, *, variant: str = "improved") -> np.ndarray:
    """Apply a subset of the paper's filters with their default settings.

    Parameters
    ----------
    image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
        RGB image.
    filters : sequence of str
        Any subset of ``("shadow", "rain_snow", "light")``; applied in the order of
        :data:`FILTERS` whatever the order given.
    variant : {"improved", "paper"}, optional
        ``"paper"`` runs the filters as §III describes them; ``"improved"`` (default)
        with the corrections the detector uses (see :data:`FILTER_VARIANTS`).

    Returns
    -------
    ndarray, same shape and dtype as ``image``
    """
    image = check_image("image", image, dtype=_IMAGE_DTYPES, channels=3)
    names = _check_filters(filters)
    variant = _check_variant(variant)
    if not names:
        return image.copy()
    return from_planes(_filter_planes(to_planes(image), names, variant), image.dtype)


def _check_training_set(images: object, masks: object) -> tuple[list[np.ndarray], list[np.ndarray]]:
    if isinstance(images, np.ndarray) and images.ndim == 3:
        raise SimroadError(
            f"images: expected a sequence of (H, W, 3) images or an (N, H, W, 3) array, got "
            f"one array of shape {images.shape}. Wrap a single image in a list: [image]."
        )
    images, masks = list(images), list(masks)
    if not images:
        raise SimroadError("images: expected at least one training image, got none.")
    if len(images) != len(masks):
        raise SimroadError(f"masks: expected one mask per image ({len(images)} images), got {len(masks)} masks.")
    imgs, msks = [], []
    for k, (img, msk) in enumerate(zip(images, masks)):
        img = check_image(f"images[{k}]", img, dtype=_IMAGE_DTYPES, channels=3, min_size=MIN_IMAGE_SIZE)
        imgs.append(img)
        msks.append(check_mask(f"masks[{k}]", msk, shape=img.shape[:2]))
    return imgs, msks


def _sample_pixels(
    images: list[np.ndarray],
    masks: list[np.ndarray],
    filters: tuple[str, ...],
    n_max: int,
    rng: np.random.Generator,
    variant: str = "improved",
) -> tuple[np.ndarray, np.ndarray]:
    """Balanced random pixels: up to ``n_max / (2 N)`` road and non-road pixels per image."""
    per = max(1, -(-n_max // (2 * len(images))))
    xs, ys = [], []
    for img, msk in zip(images, masks):
        rgb = _filtered_rgb(img, filters, variant)
        flat = msk.ravel()
        for label in (False, True):
            idx = np.flatnonzero(flat == label)
            if len(idx) > per:
                idx = rng.choice(idx, per, replace=False)
            xs.append(rgb[idx])
            ys.append(np.full(len(idx), int(label)))
    x, y = np.concatenate(xs), np.concatenate(ys)
    if y.min() == y.max():
        kind = "road" if y[0] else "non-road"
        raise SimroadError(
            f"masks: every training pixel is {kind}; the SVM needs both road and "
            "non-road pixels. Add images whose masks contain both."
        )
    return x, y


def _filtered_rgb(image: np.ndarray, filters: tuple[str, ...], variant: str = "improved") -> np.ndarray:
    """Filtered colours of every pixel as (H * W, 3) float64 rows in [0, 1]."""
    if filters:
        planes = _filter_planes(to_planes(image), filters, variant)
        return np.stack([p.ravel() for p in planes], axis=1).astype(np.float64)
    return image.reshape(-1, 3) / (255.0 if image.dtype == np.uint8 else 1.0)


def _filtered_uint8_planes(image: np.ndarray, filters: tuple[str, ...], variant: str = "improved") -> list[np.ndarray]:
    """Filtered image as three uint8 (H, W) planes, the lookup table's input."""
    if filters:
        return planes_to_uint8(_filter_planes(to_planes(image), filters, variant))
    if image.dtype != np.uint8:
        return planes_to_uint8([np.ascontiguousarray(image[..., c], dtype=np.float32) for c in range(3)])
    return [image[..., c] for c in range(3)]


def _resolve_gamma(gamma: object, x: np.ndarray) -> float:
    if isinstance(gamma, str):
        check_choice("gamma", gamma, ["scale"])
        var = float(x.var())
        return 1.0 / (x.shape[1] * var) if var > 0 else 1.0
    return check_in_range("gamma", gamma, 0.0, 1e6, low_inclusive=False)


def default_model_path() -> Path:
    """Path of the model shipped with simroad, ``simroad/data/road_detector.npz``."""
    return Path(str(importlib.resources.files("simroad").joinpath("data", "road_detector.npz")))


class RoadDetector(BaseEstimator):
    """The paper's road detector (§III): filters, HSI colour features, SVM, morphology.

    Parameters
    ----------
    filters : sequence of str, optional
        Any subset of ``("shadow", "rain_snow", "light")``; always applied in the order
        of :data:`FILTERS`. Empty (default) runs the detector without filters.
    morphology : bool, optional
        Keep the ego's road component and fill its holes (eq. 31). Default True.
    C : float, optional
        SVM soft-margin penalty, > 0.
    gamma : "scale" or float, optional
        RBF kernel width on the standardised features; ``"scale"`` is
        ``1 / (n_features * var(X))`` as in scikit-learn.
    max_samples : int, optional
        Training pixels drawn from all images together, half road and half
        non-road, spread evenly over the images. The SVM's cost grows roughly with
        its square.
    nonroad_weight : float, optional
        Cost of calling a non-road training pixel road, relative to missing a road
        pixel (the SVM's ``class_weight={0: nonroad_weight, 1: 1}``), > 0. Above 1
        trades a little FNR for a lower FPR: a car steered by the mask is hurt more
        by a shoulder taken for road than by a road pixel missed. Default 1.
    lut_bits : int, optional
        Coarse levels per RGB channel of the lookup table are ``2**lut_bits`` (5-7);
        cells near the decision boundary are stored at full 8-bit resolution either
        way (see :class:`~simroad.detector.lut.ColourTable`). 6 builds fastest.
    random_state : int, optional
        Seed of the pixel sampling.
    filter_variant : {"improved", "paper"}, optional
        ``"paper"`` runs the filters as §III describes them, ``"improved"`` (default)
        with the corrections measured in the README (see :func:`apply_filters`).

    Attributes
    ----------
    feature_mean_, feature_scale_ : ndarray, float64, (3,)
        Standardisation of the features ``(I, S cos H, S sin H)``.
    svm_ : KernelExpansion
        The trained SVM as arrays (eq. 30).
    svc_ : sklearn.svm.SVC or None
        The scikit-learn model behind ``svm_``; only after :meth:`fit` in this
        process (None for a loaded model, which is not pickled).
    lut_ : ColourTable
        The SVM tabulated for every 8-bit RGB colour (see :mod:`simroad.detector.lut`).
    n_features_in_ : int
        3.

    Notes
    -----
    Features: per-pixel ``(I, S cos H, S sin H)`` from eqs. 10-12, unsmoothed -- see
    :mod:`simroad.detector.features` for the measurements behind that choice.
    ``fit`` applies the configured filters to the training images first, so the SVM
    sees what ``predict`` will see.

    Measured with the shipped model (``simroad train-detector``: 12 clean frames of
    every scenario in each of the worlds 0-15, 16000 training pixels, non-road weight
    2) on the 300 clean frames of ``simroad evaluate-detector`` (held-out worlds
    100-104, all three scenarios): pooled FNR 1.8 %, FPR 1.7 % without filters; FNR
    4.5 %, FPR 1.2 % with all three. 320x180 on one core: about 1 ms without filters
    and 4-7 ms with all three (quiet machine), 100-150x faster than the literal
    per-pixel ``SVC.predict``, whose cost grows with the number of support vectors
    (``benchmarks/bench_detector.py``).
    """

    def __init__(
        self,
        filters: Sequence[str] = (),
        *,
        morphology: bool = True,
        C: float = 10.0,
        gamma: str | float = "scale",
        max_samples: int = 8000,
        nonroad_weight: float = 1.0,
        lut_bits: int = 6,
        random_state: int = 0,
        filter_variant: str = "improved",
    ) -> None:
        self.filters = filters
        self.filter_variant = filter_variant
        self.morphology = morphology
        self.C = C
        self.gamma = gamma
        self.max_samples = max_samples
        self.nonroad_weight = nonroad_weight
        self.lut_bits = lut_bits
        self.random_state = random_state

    # ------------------------------------------------------------------ fitting
    def fit(self, images: Sequence[np.ndarray], masks: Sequence[np.ndarray]) -> RoadDetector:
        """Learn the SVM from images and their ground-truth road masks.

        Parameters
        ----------
        images : sequence of ndarray (H, W, 3), or ndarray (N, H, W, 3)
            RGB images, uint8 or float in [0, 1]; sizes may differ (at least 8x8).
        masks : sequence of ndarray (H, W), or ndarray (N, H, W)
            Bool road masks (0/1 integers are accepted), one per image.

        Returns
        -------
        self
        """
        filters = _check_filters(self.filters)
        C = check_in_range("C", self.C, 0.0, 1e6, low_inclusive=False)
        n_max = check_int_in_range("max_samples", self.max_samples, 2, 1_000_000)
        weight = check_in_range("nonroad_weight", self.nonroad_weight, 0.0, 1e3, low_inclusive=False)
        bits = check_int_in_range("lut_bits", self.lut_bits, 5, 7)
        rng = normalize_rng(self.random_state, name="random_state")
        imgs, msks = _check_training_set(images, masks)
        variant = _check_variant(self.filter_variant)
        x, y = _sample_pixels(imgs, msks, filters, n_max, rng, variant)
        feats = _features_f(x)
        mean = feats.mean(axis=0)
        scale = feats.std(axis=0)
        scale[scale < 1e-9] = 1.0
        z = (feats - mean) / scale
        svc = SVC(C=C, kernel="rbf", gamma=_resolve_gamma(self.gamma, z), class_weight={0: weight, 1: 1.0}).fit(z, y)
        self._set_model(mean, scale, KernelExpansion.from_svc(svc), bits, None)
        self.svc_ = svc
        return self

    def _set_model(self, mean, scale, svm: KernelExpansion, bits: int, lut: ColourTable | None) -> None:
        self.feature_mean_ = np.asarray(mean, dtype=np.float64)
        self.feature_scale_ = np.asarray(scale, dtype=np.float64)
        self.svm_ = svm
        self.svc_ = None
        self.n_features_in_ = N_FEATURES
        self.lut_ = ColourTable.build(self._decide_rgb, bits) if lut is None else lut

    def _decide_rgb(self, rgb: np.ndarray) -> np.ndarray:
        """Exact SVM decision (eq. 30) for RGB rows (N, 3) in [0, 1]; (N,) bool."""
        z = (_features_f(rgb) - self.feature_mean_) / self.feature_scale_
        return self.svm_.predict(z)

    # --------------------------------------------------------------- prediction
    def predict(self, image: np.ndarray, *, exact: bool = False) -> np.ndarray:
        """Detect the road in one image.

        Parameters
        ----------
        image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
            RGB image, at least 8x8 pixels.
        exact : bool, optional
            False (default): classify by the lookup table ``lut_``. True: evaluate
            the SVM (eq. 30) at every pixel's exact colour -- the paper's literal,
            ~100x slower path, kept for checking.

        Returns
        -------
        ndarray, bool, (H, W)
            True on road.
        """
        check_is_fitted(self, "lut_", msg=_NOT_FITTED)
        image = check_image("image", image, dtype=_IMAGE_DTYPES, channels=3, min_size=MIN_IMAGE_SIZE)
        filters = _check_filters(self.filters)
        variant = _check_variant(self.filter_variant)
        if exact:
            mask = self._decide_rgb(_filtered_rgb(image, filters, variant)).reshape(image.shape[:2])
        else:
            mask = self.lut_.lookup(_filtered_uint8_planes(image, filters, variant))
        if self.morphology:
            mask = _fill_holes(_ego_component(mask))
        return mask

    # -------------------------------------------------------------- persistence
    def save(self, path: str | os.PathLike) -> None:
        """Write the fitted model to ``path`` as a compressed ``.npz`` (no pickle).

        Arrays: ``support_vectors``, ``dual_coef``, ``intercept``, ``gamma``,
        ``feature_mean``, ``feature_scale``, and the lookup table (bit-packed ``lut``,
        ``lut_bits``, ``lut_refined_cells``, bit-packed ``lut_fine``);
        ``meta`` is a JSON string with the format name/version and the parameters.
        The file is written to a temporary name and renamed, so it is never partial.
        """
        check_is_fitted(self, "lut_", msg=_NOT_FITTED)
        params = self.get_params()
        params["filters"] = list(_check_filters(params["filters"]))
        meta = {
            "format": _FORMAT,
            "version": _FORMAT_VERSION,
            "params": params,
            "features": "I, S cos H, S sin H (paper eqs. 10-12), unsmoothed",
            "n_support": len(self.svm_.dual_coef),
        }
        path = Path(path)
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh,
                support_vectors=self.svm_.support_vectors,
                dual_coef=self.svm_.dual_coef,
                intercept=np.float64(self.svm_.intercept),
                gamma=np.float64(self.svm_.gamma),
                feature_mean=self.feature_mean_,
                feature_scale=self.feature_scale_,
                meta=np.array(json.dumps(meta)),
                **self.lut_.to_arrays(),
            )
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: str | os.PathLike) -> RoadDetector:
        """Read a model written by :meth:`save` (arrays only; pickles are refused)."""
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except FileNotFoundError:
            raise SimroadError(
                f"path: no model file at {str(path)!r}. Train one with RoadDetector().fit(...).save(path) "
                "or `simroad train-detector`."
            ) from None
        except (OSError, ValueError) as exc:
            raise SimroadError(f"path: {str(path)!r} is not a simroad road-detector .npz file ({exc}).") from None
        return cls._from_arrays(arrays, str(path))

    @classmethod
    def _from_arrays(cls, arrays: dict, where: str) -> RoadDetector:
        needed = {"support_vectors", "dual_coef", "intercept", "gamma", "feature_mean", "feature_scale", "meta",
                  "lut", "lut_bits", "lut_refined_cells", "lut_fine"}  # fmt: skip
        missing = sorted(needed - set(arrays))
        if missing:
            raise SimroadError(f"path: {where!r} is not a simroad road-detector file; missing {missing}.")
        try:
            meta = json.loads(str(arrays["meta"]))
            if meta.get("format") != _FORMAT or meta.get("version") != _FORMAT_VERSION:
                raise ValueError(f"format {meta.get('format')!r} version {meta.get('version')!r}")
            det = cls(**meta["params"])
            sv = np.asarray(arrays["support_vectors"], dtype=np.float64)
            coef = np.asarray(arrays["dual_coef"], dtype=np.float64).ravel()
            if sv.ndim != 2 or sv.shape[1] != N_FEATURES or len(coef) != len(sv):
                raise ValueError("inconsistent array shapes")
            lut = ColourTable.from_arrays(arrays)
            svm = KernelExpansion(sv, coef, float(arrays["intercept"]), float(arrays["gamma"]))
        except (ValueError, TypeError, KeyError) as exc:
            raise SimroadError(
                f"path: {where!r} holds a damaged or incompatible road-detector model ({exc})."
            ) from None
        det._set_model(arrays["feature_mean"], arrays["feature_scale"], svm, lut.bits, lut)
        return det

    @classmethod
    def pretrained(
        cls, filters: Sequence[str] = (), *, morphology: bool = True, filter_variant: str = "improved"
    ) -> RoadDetector:
        """The model shipped with simroad (``simroad/data/road_detector.npz``).

        It was trained on clean rendered frames without filters (see
        :func:`train_default`); ``filters``, ``morphology`` and ``filter_variant``
        (``"improved"`` or the paper's ``"paper"``) choose how it runs.
        """
        path = default_model_path()
        if not path.is_file():
            raise SimroadError(
                f"pretrained: the packaged model {str(path)!r} is missing. Reinstall simroad or "
                "train one with `simroad train-detector`."
            )
        det = cls.load(path)
        det.set_params(
            filters=tuple(_check_filters(filters)), morphology=bool(morphology),
            filter_variant=_check_variant(filter_variant),
        )  # fmt: skip
        return det


def train_default(
    images: Sequence[np.ndarray], masks: Sequence[np.ndarray], *, rng: np.random.Generator | int
) -> RoadDetector:
    """Train the default detector (no filters, morphology on) as shipped with simroad:
    :data:`DEFAULT_MAX_SAMPLES` training pixels, non-road cost :data:`DEFAULT_NONROAD_WEIGHT`.

    Parameters
    ----------
    images : sequence of ndarray (H, W, 3)
        Clean RGB frames (uint8 or float in [0, 1]); use several seeds, i.e.
        several world palettes.
    masks : sequence of ndarray (H, W), bool
        Their ground-truth road masks.
    rng : numpy.random.Generator or int
        Draws the training pixels.

    Returns
    -------
    RoadDetector
        Fitted; save it with ``.save(default_model_path())``.
    """
    rng = normalize_rng(rng)
    seed = int(rng.integers(0, 2**31 - 1))
    return RoadDetector(
        (), morphology=True, max_samples=DEFAULT_MAX_SAMPLES, nonroad_weight=DEFAULT_NONROAD_WEIGHT, random_state=seed
    ).fit(images, masks)
