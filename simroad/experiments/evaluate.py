"""Score the detector offline on frames (``simroad evaluate-detector``); draw the paper's Figs. 3-6.

:func:`evaluate_detector` renders held-out frames (or reads a folder of real images
and masks) and scores each filter setting; :func:`evaluate_frames` does the scoring
on frames you already have; :func:`qualitative_figure` draws the paper's
qualitative figure.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from simroad.camera.profile import CameraProfile, resolve_profile
from simroad.core.names import HELD_OUT_SEEDS
from simroad.core.validation import check_choice, check_in_range, check_int_in_range
from simroad.detector import RoadDetector
from simroad.detector.registry import load_detector, predict_alone
from simroad.envs import SCENARIO_NAMES
from simroad.errors import InvalidParameterError, SimroadError
from simroad.experiments.figures import check_figure_path
from simroad.experiments.frames import FrameSet, check_frame_protocol, collect_frames
from simroad.experiments.photos import load_image_folder
from simroad.experiments.video import overlay_frame
from simroad.filters import format_filters, parse_filters
from simroad.filters.pipeline import FILTER_REGISTRY, FILTERS
from simroad.metrics.mask import MaskScore

__all__ = [
    "FIGURE_NOISES",
    "FILTER_MASK_TRUTH",
    "detector_factory",
    "evaluate_detector",
    "evaluate_frames",
    "figure_panels",
    "filter_mask",
    "format_table",
    "model_factory",
    "qualitative_figure",
]

#: A detector for a filter setting: ``filters -> fitted detector``.
DetectorFactory = Callable[[tuple[str, ...]], Any]

#: The filters that detect where their weather acts (each returns that mask), by name.
_MASK_DETECTORS = ("shadow", "light")
#: Which ground-truth noise mask a filter's own detection mask is scored against: the
#: weather the filter is registered for.
FILTER_MASK_TRUTH = {name: FILTER_REGISTRY[name].weathers[0] for name in _MASK_DETECTORS}


def filter_mask(name: str, image: np.ndarray, variant: str = "improved") -> np.ndarray:
    """Where the filter ``name`` (its ``variant``'s steps, as the detector runs them)
    detects its weather in ``image``: the mask of its last step. (Not the steps' masks
    united, as :func:`~simroad.filters.pipeline.filter_planes_masks` reports where a
    filter acted: the improved shadow filter's first step, the colour-cast removal,
    acts on the whole frame.)"""
    mask = np.zeros(image.shape[:2], bool)
    for step in FILTER_REGISTRY[name].steps(variant):
        image, mask = step.function(image, **step.settings)
    return mask


def _filter_mask_scores(frames: FrameSet, filters: Sequence[str], variant: str) -> dict[str, MaskScore]:
    scores: dict[str, MaskScore] = {}
    for name in filters:
        truth_name = FILTER_MASK_TRUTH.get(name)
        if truth_name is None:
            continue
        score = MaskScore()
        for img, noise in zip(frames.images, frames.noise_masks):
            if truth_name in noise:
                score.update(filter_mask(name, img, variant), noise[truth_name])
        if score.n_frames:
            scores[f"{name} filter ({variant}) vs GT {truth_name}"] = score
    return scores


def _pretrained(filters: tuple[str, ...]) -> Any:

    return RoadDetector.pretrained(filters=filters)


def detector_factory(
    model: str | os.PathLike | None, detector: str = "paper", options: Mapping[str, Any] | None = None
) -> DetectorFactory:
    """``filters -> detector`` for a model file (the paper's detector) or a detector spec."""
    if model is not None and detector != "paper":
        raise InvalidParameterError(
            f"model: a model file is for the paper's detector; got it with detector={detector!r}. Give one of them."
        )
    return model_factory(model) if model is not None else _spec_factory(detector, options)


def _spec_factory(spec: str, options: Mapping[str, Any] | None) -> DetectorFactory:
    """Build the detector ``spec`` names with ``options``, checked now (a bad spec
    fails before any frame is rendered), each filter setting in front."""

    load_detector(spec, options)
    return lambda filters: load_detector(spec, options, filters=filters)


def model_factory(path: str | os.PathLike) -> DetectorFactory:
    """A detector factory for the model file at ``path`` (read once, checked now):
    its own filter setting returns the loaded detector, another setting a fresh copy
    set to those filters."""

    try:
        base = RoadDetector.load(path)
    except SimroadError as exc:
        raise InvalidParameterError(f"model: {exc}") from None

    def factory(filters: tuple[str, ...]) -> Any:
        if filters == tuple(base.filters):
            return base
        return RoadDetector.load(path).set_params(filters=filters)

    return factory


def evaluate_frames(
    frames: FrameSet, settings: Sequence[tuple[str, ...]], *, detector_factory: DetectorFactory | None = None
) -> tuple[list[dict], list[dict]]:
    """Score each filter setting's masks on ``frames``; also the filters' own masks.

    Parameters
    ----------
    frames : FrameSet
        Frames with their ground-truth road masks, valid-pixel masks and (for the
        filter-mask rows) ground-truth noise masks.
    settings : sequence of tuple of str
        Filter settings, e.g. ``[(), ("shadow", "rain_snow", "light")]``.
    detector_factory : callable, optional
        ``filters -> fitted detector``; default the shipped model
        (:meth:`RoadDetector.pretrained`).

    Returns
    -------
    rows : list of dict
        One per setting: ``filters`` (text), ``frames``, and (fractions) ``fnr``,
        ``fpr`` pooled over the valid pixels of the frames (rendered frames: the
        ground below the horizon), ``fnr_image``, ``fpr_image`` pooled over every
        pixel (rendered frames: the sky and all above the horizon count as non-road;
        a photo's whole image is its labelled image, so there they equal ``fnr``,
        ``fpr``), and ``iou``, ``f1`` on the valid pixels.
    filter_rows : list of dict
        One per filter with its own detection mask (shadow, light) and frames whose
        noise it detects: ``mask``, ``frames``, ``precision``, ``recall``, ``iou``,
        ``f1`` against the ground-truth noise mask.
    """
    factory = detector_factory or _pretrained
    rows, variants = [], []
    for filters in settings:
        det = factory(tuple(filters))
        if filters:
            variants.append(getattr(det, "filter_variant", "improved"))
        score, whole = MaskScore(), MaskScore()
        for img, gt, valid in zip(frames.images, frames.masks, frames.valid):
            pred = predict_alone(det, img)
            score.update(pred, gt, valid=valid)
            whole.update(pred, gt)
        s, w = score.summary(), whole.pooled()
        rows.append(
            {
                "filters": format_filters(filters),
                "frames": score.n_frames,
                **{k: s[k] for k in ("fnr", "fpr")},
                "fnr_image": w["fnr"],
                "fpr_image": w["fpr"],
                **{k: s[k] for k in ("iou", "f1")},
            }
        )
    all_filters = sorted({f for setting in settings for f in setting})
    # the filters' own masks as the detectors ran them: their variant (the shipped default otherwise)
    variant = variants[0] if variants else "improved"
    frows = []
    for name, score in _filter_mask_scores(frames, all_filters, variant).items():
        s = score.summary()
        frows.append(
            {"mask": name, "frames": score.n_frames, **{k: s[k] for k in ("precision", "recall", "iou", "f1")}}
        )
    return rows, frows


def evaluate_detector(
    settings: Sequence[str | Sequence[str]] = ("none", "all"),
    *,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    noise: str = "clear",
    severity: float = 0.7,
    seeds: Sequence[int] = HELD_OUT_SEEDS,
    frames_per_seed: int = 20,
    images: str | os.PathLike | None = None,
    masks: str | os.PathLike | None = None,
    model: str | os.PathLike | None = None,
    detector: str = "paper",
    detector_options: Mapping[str, Any] | None = None,
    camera_profile: CameraProfile | str | os.PathLike | None = None,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
) -> tuple[list[dict], list[dict]]:
    """Score a detector on held-out rendered frames, or on a folder of images and masks.

    Parameters
    ----------
    settings : sequence of str or sequence of str
        Filter settings as :func:`parse_filters` reads them (``"none"``, ``"all"``,
        ``"shadow+light"``, or tuples of names).
    scenarios, noise, severity, seeds, frames_per_seed
        The rendered frames (see :func:`~simroad.experiments.frames.collect_frames`):
        one episode per scenario and seed (default :data:`HELD_OUT_SEEDS`, worlds
        the shipped model never saw), a frame every 4 policy steps; severity in [0, 1].
    images, masks : path, optional
        Folders of real images and their road masks (both or neither), read by
        :func:`~simroad.experiments.photos.load_image_folder` instead of rendering.
    road_value, road_colour : optional
        How to read label-image or colour masks
        (:func:`~simroad.experiments.photos.read_road_mask`); black-and-white and 0/1
        masks need neither.
    model : path, optional
        A detector ``.npz`` (e.g. from ``simroad train-detector``) instead of the
        shipped model.
    detector, detector_options
        Any detector by spec (:func:`simroad.detector.registry.load_detector`), built
        with its options and each setting's filters in front; ``paper`` (default) is
        the shipped model. Not with ``model``.
    camera_profile : CameraProfile, dict or path, optional
        The camera of the rendered frames (RoadCam's ``camera_profile``); not with
        ``images`` (photographs come from their own camera).

    Returns
    -------
    rows, filter_rows : list of dict
        As :func:`evaluate_frames` returns them.
    """
    if isinstance(settings, str) or not settings:
        raise InvalidParameterError(
            f"settings: expected a list of filter settings such as ['none', 'all'], got {settings!r}."
        )
    parsed = [parse_filters(f) for f in settings]
    if images is not None or masks is not None:
        if images is None or masks is None:
            raise InvalidParameterError("images: --images and --masks go together.")
        if camera_profile is not None:
            raise InvalidParameterError(
                "camera_profile: sets the camera of rendered frames; the images come from their own camera. "
                "Drop one of them."
            )
    elif road_value is not None or road_colour is not None:
        raise InvalidParameterError("road_value: reads the masks of --images and --masks; give those too.")
    else:
        check_frame_protocol(scenarios=scenarios, seeds=seeds, noise=noise, severity=severity)
        check_int_in_range("frames_per_seed", frames_per_seed, 1, 100_000)
    factory = detector_factory(model, detector, detector_options)
    if images is not None and masks is not None:
        frames = load_image_folder(images, masks, road_value=road_value, road_colour=road_colour)
    else:
        options = {} if camera_profile is None else {"camera_profile": resolve_profile(camera_profile)}
        frames = collect_frames(
            scenarios=scenarios, seeds=seeds, frames_per_seed=frames_per_seed, noise=noise, severity=severity,
            env_options=options,
        )  # fmt: skip
    return evaluate_frames(frames, parsed, detector_factory=factory)


def format_table(rows: list[dict], *, percent: Sequence[str] = ()) -> str:
    """A plain text table of dict rows."""
    if not rows:
        return "(no rows)"
    cols = list(rows[0])

    def cell(k: str, v: object) -> str:
        if isinstance(v, float):
            return f"{100 * v:.2f}%" if k in percent else f"{v:.3f}"
        return str(v)

    text = [[cell(k, r[k]) for k in cols] for r in rows]
    widths = [max(len(c), *(len(t[i]) for t in text)) for i, c in enumerate(cols)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(cols, widths))]
    lines += ["  ".join(v.rjust(w) for v, w in zip(t, widths)) for t in text]
    return "\n".join(lines)


#: The weathers of the paper's qualitative figure (Figs. 3-6).
FIGURE_NOISES = ("glare", "shadow", "snow", "rain")


def figure_panels(
    *,
    scenarios: Sequence[str] = ("winding",),
    seed: int = 0,
    noises: Sequence[str] = FIGURE_NOISES,
    severity: float = 0.7,
    settings: Sequence[Sequence[str]] = ((), FILTERS),
    detector_factory: DetectorFactory | None = None,
) -> list[tuple[str, str, np.ndarray, np.ndarray, list[tuple[str, np.ndarray]]]]:
    """The rows of :func:`qualitative_figure`: per scenario and noise ``(scenario,
    noise, frame, ground truth, [(filter setting, mask), ...])``, each mask the
    detector's ``predict`` on the frame on its own (:func:`predict_alone`)."""
    for scenario in scenarios:
        check_choice("scenario", scenario, SCENARIO_NAMES)
    seed = check_int_in_range("seed", seed, 0, 2**31 - 1)
    severity = check_in_range("severity", severity, 0.0, 1.0)
    factory = detector_factory or _pretrained
    detectors = [(format_filters(tuple(f)), factory(tuple(f))) for f in settings]
    rows = []
    for scenario in scenarios:
        for noise in noises:
            fs = collect_frames(
                scenarios=(scenario,), seeds=(seed,), frames_per_seed=1, noise=noise, severity=severity, every=8
            )
            img, gt = fs.images[0], fs.masks[0]
            rows.append((scenario, noise, img, gt, [(name, predict_alone(det, img)) for name, det in detectors]))
    return rows


def qualitative_figure(
    path: str | os.PathLike,
    *,
    scenarios: Sequence[str] = ("winding",),
    seed: int = 0,
    noises: Sequence[str] = FIGURE_NOISES,
    severity: float = 0.7,
    settings: Sequence[Sequence[str]] = ((), FILTERS),
    detector_factory: DetectorFactory | None = None,
    detector_name: str = "paper",
) -> Path:
    """The paper's Figs. 3-6: per scenario and noise the noisy frame with the ground
    truth's outline, then the detector's mask for each filter setting
    (:func:`figure_panels`; by default the shipped detector without and with all
    filters, on the four weathers of the paper)."""
    out = check_figure_path("figure", path)
    rows = figure_panels(scenarios=scenarios, seed=seed, noises=noises, severity=severity, settings=settings,
                         detector_factory=detector_factory)  # fmt: skip
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 1 + len(settings)
    fig, axes = plt.subplots(len(rows), cols, figsize=(3.4 * cols, 1.95 * len(rows)), squeeze=False)
    for ax_row, (scenario, noise, img, gt, masks) in zip(axes, rows):
        shown = f"{noise} {severity:g}" if noise != "clear" else "clear"
        panels = [(overlay_frame(img, gt, None), f"{scenario}, {shown}: GT outline")]
        panels += [(overlay_frame(img, gt, m), f"{detector_name}, filters {name}") for name, m in masks]
        for ax, (im, title) in zip(ax_row, panels):
            ax.imshow(im)
            ax.set_title(title, fontsize=8)
            ax.axis("off")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=85)
    plt.close(fig)
    return out
