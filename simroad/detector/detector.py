"""The paper's road detector as a scikit-learn style estimator: filters -> HSI features -> SVM -> morphology (§III).

``RoadDetector`` stores its arguments in ``__init__``; ``fit(images, masks)`` learns an
RBF SVM on per-pixel colour features of any RGB images with bool road masks (rendered
frames or photographs), ``predict`` returns a bool road mask and leaves the detector
unchanged; an episode's frames in order go through :meth:`RoadDetector.episode`
(:mod:`simroad.detector.episode`: the camera's ground, the glare memory). The filters run by name
from :mod:`simroad.filters` in one of two variants (``filter_variant``, see
:data:`~simroad.filters.FILTER_REGISTRY`); ``simroad filter-effect`` measures each
against no filter on its own weather. Pixel sampling lives in
:mod:`simroad.detector.pixels`, model files in :mod:`simroad.detector.persistence`,
the shipped model's training in :mod:`simroad.detector.training`.
"""

from __future__ import annotations

import importlib.resources
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.exceptions import NotFittedError
from sklearn.svm import SVC
from sklearn.utils.validation import check_is_fitted

from simroad.core.validation import (
    IMAGE_DTYPES,
    check_bool,
    check_choice,
    check_image,
    check_in_range,
    check_int_in_range,
    normalize_rng,
)
from simroad.detector.episode import DetectorEpisode, GlareMemory, _check_ground, _through_glare
from simroad.detector.features import N_FEATURES, _features_f
from simroad.detector.lut import ColourTable
from simroad.detector.morphology import _ego_component, _ego_component_apart, _fill_holes, extend_upward
from simroad.detector.persistence import check_model_destination, parse_model, read_arrays, write_model
from simroad.detector.pixels import (
    MIN_IMAGE_SIZE,
    check_training_set,
    filtered_rgb_masks,
    filtered_table_planes_masks,
    sample_pixels,
)
from simroad.detector.reference import NORMALIZATIONS, marking_mask, normalize_planes, normalize_rows
from simroad.detector.svm import KernelExpansion
from simroad.errors import InvalidParameterError, ModelFileError
from simroad.filters.pipeline import check_filters, check_variant

__all__ = [
    "DEFAULT_MAX_SAMPLES",
    "RoadDetector",
    "default_model_path",
]

#: Training pixels of :class:`RoadDetector` by default, as many as the shipped model's
#: (:data:`~simroad.detector.training.SHIPPED_MAX_SAMPLES`).
DEFAULT_MAX_SAMPLES = 16000
_NOT_FITTED = (
    "This %(name)s is not fitted yet. Call fit(images, masks) first, or get a trained "
    "one with RoadDetector.pretrained() or RoadDetector.load(path)."
)


def _resolve_gamma(gamma: object, x: np.ndarray) -> float:
    if isinstance(gamma, str):
        check_choice("gamma", gamma, ["scale"])
        var = float(x.var())
        return 1.0 / (x.shape[1] * var) if var > 0 else 1.0
    return check_in_range("gamma", gamma, 0.0, 1e6, low_inclusive=False)


def default_model_path() -> Path:
    """Path of the model shipped with simroad, ``simroad/data/road_detector.npz``."""
    return Path(str(importlib.resources.files("simroad") / "data" / "road_detector.npz"))


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
        non-road, spread evenly over the images; default
        :data:`DEFAULT_MAX_SAMPLES`, as for the shipped model. The SVM's cost grows
        roughly with its square.
    nonroad_weight : float, optional
        Cost of calling a non-road training pixel road, relative to missing a road
        pixel (the SVM's ``class_weight={0: nonroad_weight, 1: 1}``), > 0. Above 1
        trades a little FNR for a lower FPR: a car steered by the mask is hurt more
        by a shoulder taken for road than by a road pixel missed. Default 1 (the
        shipped model was trained with
        :data:`~simroad.detector.training.SHIPPED_NONROAD_WEIGHT`, 2).
    lut_bits : int, optional
        Coarse levels per RGB channel of the lookup table are ``2**lut_bits`` (5-7);
        cells near the decision boundary are stored at full 8-bit resolution either
        way (see :class:`~simroad.detector.lut.ColourTable`). 6 builds fastest.
    random_state : int, optional
        Seed of the pixel sampling.
    filter_variant : {"improved", "paper"}, optional
        ``"paper"`` runs the filters as §III describes them, ``"improved"`` (default)
        with the corrections measured in the README (see :func:`apply_filters`); its
        morphology also keeps lane markings from bridging the road to a pale verge
        (:mod:`simroad.detector.reference`).
    normalize : {"none", "road_ahead"}, optional
        ``"none"`` (default, §III): the SVM classifies absolute colours.
        ``"road_ahead"``: every image (in ``fit`` and ``predict``, after the filters)
        is first scaled per channel so that the road just ahead of the car comes out
        at one grey (:func:`~simroad.detector.reference.road_ahead_gains`); the
        classifier learns colours relative to the road under the car, whatever the
        camera's exposure and white balance. The shipped model uses it.

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

    The shipped model (``simroad train-detector``: 12 clean frames of every scenario
    in each of the worlds 0-15, 16000 training pixels, non-road weight 2) is scored by
    ``simroad evaluate-detector`` on held-out worlds; the README gives its FNR and FPR.
    Classifying by the lookup table is two orders of magnitude faster than the literal
    per-pixel ``SVC.predict``, whose cost grows with the number of support vectors;
    with all three filters the filters cost several times the classification.
    ``make bench`` (``benchmarks/bench_detector.py``) measures both on the machine at hand.
    """

    def __init__(
        self,
        *,
        filters: Sequence[str] = (),
        morphology: bool = True,
        C: float = 10.0,
        gamma: str | float = "scale",
        max_samples: int = DEFAULT_MAX_SAMPLES,
        nonroad_weight: float = 1.0,
        lut_bits: int = 6,
        random_state: int = 0,
        filter_variant: str = "improved",
        normalize: str = "none",
    ) -> None:
        self.filters = filters
        self.normalize = normalize
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
        filters = check_filters(self.filters)
        check_bool("morphology", self.morphology)
        C = check_in_range("C", self.C, 0.0, 1e6, low_inclusive=False)
        n_max = check_int_in_range("max_samples", self.max_samples, 2, 1_000_000)
        weight = check_in_range("nonroad_weight", self.nonroad_weight, 0.0, 1e3, low_inclusive=False)
        bits = check_int_in_range("lut_bits", self.lut_bits, 5, 7)
        rng = normalize_rng(self.random_state, name="random_state")
        imgs, msks = check_training_set(images, masks)
        variant = check_variant(self.filter_variant)
        normalize = check_choice("normalize", self.normalize, NORMALIZATIONS)
        x, y = sample_pixels(imgs, msks, filters, n_max, rng, variant, normalize)
        feats = _features_f(x)
        mean = feats.mean(axis=0)
        scale = feats.std(axis=0)
        scale[scale < 1e-9] = 1.0
        z = (feats - mean) / scale
        svc = SVC(C=C, kernel="rbf", gamma=_resolve_gamma(self.gamma, z), class_weight={0: weight, 1: 1.0}).fit(z, y)
        self._set_model(mean, scale, KernelExpansion.from_svc(svc), bits, None)
        self.svc_ = svc
        return self

    def _set_model(self, mean: Any, scale: Any, svm: KernelExpansion, bits: int, lut: ColourTable | None) -> None:
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
        """Detect the road in one image, on its own; the detector is left unchanged.

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

        Notes
        -----
        A frame of a sequence may need what came before it: with the ``"improved"``
        variant, the light filter and ``morphology``, the road comes from region growth
        on the :data:`~simroad.detector.episode.GLARE_MEMORY_FRAMES` frames after the
        light filter removed a sun's lobe, and a known camera keeps the road below its
        horizon. :meth:`episode` predicts an episode's frames in order with both;
        ``predict`` is the first frame of an episode without a camera.
        """
        return self.predict_step(image, GlareMemory(), exact=exact)[0]

    def predict_step(
        self, image: np.ndarray, memory: GlareMemory, *, ground: np.ndarray | None = None, exact: bool = False
    ) -> tuple[np.ndarray, GlareMemory]:
        """Detect the road in the next frame of an episode: a pure function of the frame,
        the episode's memory and the camera's ground; the detector is left unchanged.

        :meth:`episode` keeps ``memory`` and ``ground`` for you; call this one to hold
        them yourself (e.g. one memory per environment of a vector env).

        Parameters
        ----------
        image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
            RGB frame, at least 8x8 pixels.
        memory : GlareMemory
            What the episode's earlier frames left (``GlareMemory()`` for its first).
        ground : ndarray, bool, (H, W), optional
            The camera's ``ground_valid``: with the ``"improved"`` variant and
            ``morphology`` on, pixels above its horizon are never road and never join
            the road. A ground of another size than the frame is not used; the
            ``"paper"`` variant ignores it (§III knows no camera).
        exact : bool, optional
            Evaluate the SVM at every pixel instead of the lookup table (see :meth:`predict`).

        Returns
        -------
        mask : ndarray, bool, (H, W)
            True on road.
        memory : GlareMemory
            What this frame leaves for the next (``memory`` itself when nothing changed).
        """
        if not hasattr(self, "lut_"):  # check_is_fitted's test, without its per-call tag machinery
            raise NotFittedError(_NOT_FITTED % {"name": type(self).__name__})
        image = check_image("image", image, dtype=IMAGE_DTYPES, channels=3, min_size=MIN_IMAGE_SIZE)
        if not isinstance(memory, GlareMemory):
            raise InvalidParameterError(
                f"memory: expected a GlareMemory (GlareMemory() for an episode's first frame), "
                f"got {type(memory).__name__}; or let detector.episode(camera) keep it."
            )
        ground = _check_ground("ground", ground)
        filters = check_filters(self.filters)
        variant = check_variant(self.filter_variant)
        exact = check_bool("exact", exact)
        normalize = check_choice("normalize", self.normalize, NORMALIZATIONS)
        mask, acted, planes = self._classify(image, filters, variant, exact, normalize)
        if not check_bool("morphology", self.morphology):
            return mask, memory
        if variant != "improved":
            return _fill_holes(_ego_component(mask)), memory
        if ground is not None and ground.shape == mask.shape:
            mask &= ground  # nothing above the horizon is road, nor joins the road
        else:
            ground = None
        mask = _ego_component_apart(mask, marking_mask(planes))
        haze = acted.get("rain_snow")
        if haze is not None and haze.any():
            mask = self._extend_through_haze(image, mask, filters, exact, normalize, ground)
        lobe = acted.get("light")
        if lobe is not None:
            mask, memory = _through_glare(image, mask, lobe, memory, ground)
        return _fill_holes(mask), memory

    def _extend_through_haze(
        self,
        image: np.ndarray,
        mask: np.ndarray,
        filters: tuple[str, ...],
        exact: bool,
        normalize: str,
        ground: np.ndarray | None,
    ) -> np.ndarray:
        """Not §III: the rain/snow filter extends the road upwards, and no further.

        Removing the veil recovers the far road; near a pale verge the classifier calls
        road (kept apart from the road by a painted line) it also joins the two through
        the far rows, and the ego's component takes the whole verge. What the filter adds
        is kept only where it continues, upwards, the road found without it.
        """
        others = tuple(f for f in filters if f != "rain_snow")
        ref = self._classify(image, others, "improved", exact, normalize)[0]
        if ground is not None:
            ref &= ground
        ref = _fill_holes(_ego_component(ref)) & mask
        return extend_upward(mask, ref) if ref.any() else mask

    def _classify(
        self, image: np.ndarray, filters: tuple[str, ...], variant: str, exact: bool, normalize: str
    ) -> tuple[np.ndarray, dict[str, np.ndarray], list[np.ndarray]]:
        """The per-pixel road mask of ``image`` after ``filters`` and ``normalize`` (the
        lookup table, or the SVM at every pixel when ``exact``), where each filter acted,
        and the R, G, B planes that were classified."""
        shape = image.shape[:2]
        if exact:
            rgb, acted = filtered_rgb_masks(image, filters, variant)
            rgb = normalize_rows(rgb, shape, normalize, acted.get("light"))
            return self._decide_rgb(rgb).reshape(shape), acted, [rgb[:, c].reshape(shape) for c in range(3)]
        planes, acted = filtered_table_planes_masks(image, filters, variant)
        planes = normalize_planes(planes, normalize, acted.get("light"))
        return self.lut_.lookup(planes), acted, planes

    def episode(self, camera: Any = None) -> DetectorEpisode:
        """Start an episode: an object that predicts its frames in order and carries what
        persists from one to the next (the camera's ground mask, the glare memory).

        The detector itself is never changed, so one detector serves any number of
        episodes, one after another or side by side; the caller owns each episode
        (the mask driver starts one per episode, :class:`~simroad.control.MaskDriver`).

        Parameters
        ----------
        camera : PinholeCamera or None, optional
            The calibrated camera the frames come from (``env.camera``; any object with
            a bool (H, W) ``ground_valid``). With the ``"improved"`` variant and
            ``morphology`` on, pixels its calibration puts above the horizon are never
            road: sky, tree tops and building fronts cannot join the road component.
            None (default): frames or photographs without a camera.

        Returns
        -------
        DetectorEpisode
            With ``predict(image, *, exact=False)``, ``reset()``, ``name`` and
            ``version``: a detector of the protocol of :mod:`simroad.detector.registry`.

        Examples
        --------
        >>> episode = detector.episode(env.camera)  # doctest: +SKIP
        >>> masks = [episode.predict(frame) for frame in frames]  # doctest: +SKIP
        """
        return DetectorEpisode(self, camera)

    # -------------------------------------------------------------- persistence
    def save(self, path: str | os.PathLike) -> None:
        """Write the fitted model to ``path`` as a compressed ``.npz`` (no pickle) with a checksum.

        The destination is checked first (:func:`~simroad.detector.check_model_destination`:
        its folder must exist and be writable). See :mod:`simroad.detector.persistence`
        for the format; the file is written to a temporary name and renamed, so it is
        never partial.
        """
        check_is_fitted(self, "lut_", msg=_NOT_FITTED)
        check_model_destination(path)
        params = self.get_params()
        params["filters"] = list(check_filters(params["filters"]))
        write_model(
            path, params=params, feature_mean=self.feature_mean_, feature_scale=self.feature_scale_,
            svm=self.svm_, lut=self.lut_,
        )  # fmt: skip

    @classmethod
    def load(cls, path: str | os.PathLike) -> RoadDetector:
        """Read a model written by :meth:`save`: arrays only (pickles are refused), every one checked.

        Returns a detector that predicts exactly what the saved one did, or raises one
        :class:`~simroad.SimroadError` naming the file and what is wrong (missing,
        empty, truncated, damaged bytes -- caught by the zip CRC or the file's SHA-256
        checksum --, wrong arrays, shapes, dtypes or values, a pickle). Files of
        format version 1 (no checksum) are still read, with all other checks.
        """
        return cls._from_arrays(read_arrays(path), str(path))

    @classmethod
    def _from_arrays(cls, arrays: dict[str, np.ndarray], where: str) -> RoadDetector:
        stored = parse_model(arrays, where)
        det = cls(**stored.params)  # parse_model checked the names and values
        det._set_model(stored.feature_mean, stored.feature_scale, stored.svm, stored.lut.bits, stored.lut)
        return det

    @classmethod
    def pretrained(
        cls, *, filters: Sequence[str] = (), morphology: bool = True, filter_variant: str = "improved"
    ) -> RoadDetector:
        """The model shipped with simroad (``simroad/data/road_detector.npz``).

        It was trained on clean rendered frames without filters (see
        :func:`train_default`); ``filters``, ``morphology`` and ``filter_variant``
        (``"improved"`` or the paper's ``"paper"``) choose how it runs.
        """
        path = default_model_path()
        if not path.is_file():
            raise ModelFileError(
                f"pretrained: the packaged model {str(path)!r} is missing. Reinstall simroad or "
                "train one with `simroad train-detector`."
            )
        det = cls.load(path)
        det.set_params(
            filters=tuple(check_filters(filters)), morphology=check_bool("morphology", morphology),
            filter_variant=check_variant(filter_variant),
        )  # fmt: skip
        return det
