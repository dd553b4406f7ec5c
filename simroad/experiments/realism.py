"""How real do the rendered frames look? Appearance statistics against real photographs (``simroad realism``).

:func:`realism_report` renders clear frames of held-out worlds (env defaults: the
camera's sensor on), computes each frame's appearance statistics
(:func:`simroad.metrics.appearance.frame_appearance`) and holds them beside a
reference of real road photographs: the shipped CamVid table, a quantile table file,
or the user's own photographs (:func:`photo_reference`). :class:`RealismReport`
gives, per statistic, p10 / median / p90 of the frames, per scenario and pooled,
beside the reference's, and the Kolmogorov-Smirnov distance to the reference
(:func:`~simroad.metrics.appearance.ks_distance`). :func:`format_realism_table`,
:func:`realism_figure` and :func:`write_realism` turn it into text, a figure and files.
"""

from __future__ import annotations

import csv
import json
import os
import textwrap
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from simroad.core.validation import check_int_in_range, check_output_dir, ensure_writable_dir
from simroad.envs import SCENARIO_NAMES
from simroad.errors import InvalidParameterError
from simroad.experiments._plotting import save_figure, start_figure
from simroad.experiments.figures import check_figure_path
from simroad.experiments.frames import check_frame_protocol, collect_frames
from simroad.experiments.photos import load_image_folder
from simroad.metrics.appearance import (
    MIN_ROAD_PIXELS,
    STATISTICS,
    AppearanceReference,
    frame_appearance,
    ks_distance,
    load_reference,
    reference_from_values,
)

__all__ = [
    "FRAME_COLUMNS",
    "FRAME_EVERY",
    "REALISM_SEEDS",
    "RealismReport",
    "check_env_options",
    "format_realism_table",
    "photo_reference",
    "photo_statistics",
    "realism_figure",
    "realism_report",
    "write_realism",
]

#: Worlds of the default report: no tuning has used them (training worlds are 0-15,
#: evaluation 100 and up, the paper's experiment 130 and up, validation 200 and up).
REALISM_SEEDS = range(5000, 5013)
#: Policy steps between the frames of an episode (the first frame is one such gap in).
FRAME_EVERY = 5
#: Columns of ``realism.csv``: where each frame comes from, then its statistics.
FRAME_COLUMNS = ("scenario", "seed", "step", *STATISTICS)
#: What each statistic measures, for tables and figure axes.
UNITS = {
    "road_V": "median V of the road (HSV, 0-1)",
    "road_S": "median S of the road (HSV, 0-1)",
    "road_b": "median b* of the road (Lab; - blue, + yellow)",
    "road_a": "median a* of the road (Lab; - green, + red)",
    "road_minus_surround": "road V - surround V (lower half, 0-1)",
    "road_spread": "p90 - p10 of the road's V (0-1)",
    "frame_V": "mean V of the frame (0-1)",
    "saturated": "share of clipped pixels (all channels >= 250)",
}
_LEVELS = (0.1, 0.5, 0.9)
#: env_options keys the report sets itself.
_OWN_KEYS = ("scenario", "noise", "severity")


@dataclass(frozen=True)
class RealismReport:
    """The appearance statistics of rendered frames beside a reference's.

    Attributes
    ----------
    frames : tuple of (str, int, int)
        ``(scenario, seed, step)`` of each frame with statistics.
    values : ndarray, float, (n_frames, len(STATISTICS))
        Each frame's statistics, in the order of :data:`STATISTICS` (NaN where a
        statistic has no value, e.g. ``road_minus_surround`` when the road fills the
        lower half).
    reference : AppearanceReference
        The real photographs' quantile tables.
    skipped : tuple of (str, int, int)
        Frames left out: fewer than :data:`MIN_ROAD_PIXELS` road pixels.
    """

    frames: tuple[tuple[str, int, int], ...]
    values: np.ndarray
    reference: AppearanceReference
    skipped: tuple[tuple[str, int, int], ...] = ()

    @property
    def scenarios(self) -> tuple[str, ...]:
        """The scenarios of the frames, in their first frame's order."""
        return tuple(dict.fromkeys(f[0] for f in self.frames))

    def sample(self, statistic: str, scenario: str | None = None) -> np.ndarray:
        """The finite values of ``statistic`` over one scenario's frames (None: all)."""
        if statistic not in STATISTICS:
            raise InvalidParameterError(f"statistic: expected one of {', '.join(STATISTICS)}, got {statistic!r}.")
        if scenario is not None and scenario not in self.scenarios:
            raise InvalidParameterError(
                f"scenario: expected one of the report's {', '.join(self.scenarios)}, got {scenario!r}."
            )
        col = self.values[:, STATISTICS.index(statistic)] if len(self.frames) else np.zeros(0)
        if scenario is not None:
            col = col[np.array([f[0] == scenario for f in self.frames], bool)]
        return col[np.isfinite(col)]

    def percentiles(self, statistic: str, scenario: str | None = None) -> np.ndarray:
        """p10, median and p90 of :meth:`sample` (NaN when it is empty)."""
        v = self.sample(statistic, scenario)
        return np.quantile(v, _LEVELS) if v.size else np.full(len(_LEVELS), np.nan)

    def ks(self, statistic: str, scenario: str | None = None) -> float:
        """KS distance of :meth:`sample` to the reference (NaN when it is empty)."""
        v = self.sample(statistic, scenario)
        return ks_distance(v, self.reference.quantiles[statistic]) if v.size else float("nan")

    def rows(self) -> list[dict[str, Any]]:
        """One dict per statistic: ``statistic``, ``ref_p10``, ``ref_p50``, ``ref_p90``,
        ``sim_p10``, ``sim_p50``, ``sim_p90`` (pooled frames), ``ks`` (pooled) and
        ``ks_<scenario>`` for each scenario."""
        out = []
        for s in STATISTICS:
            row: dict[str, Any] = {"statistic": s}
            row.update(zip(("ref_p10", "ref_p50", "ref_p90"), map(float, self.reference.percentiles(s, _LEVELS))))
            row.update(zip(("sim_p10", "sim_p50", "sim_p90"), map(float, self.percentiles(s))))
            row["ks"] = self.ks(s)
            row.update({f"ks_{sc}": self.ks(s, sc) for sc in self.scenarios})
            out.append(row)
        return out

    def frame_rows(self) -> list[dict[str, Any]]:
        """One dict per frame with the keys of :data:`FRAME_COLUMNS`."""
        return [
            {"scenario": sc, "seed": seed, "step": step, **dict(zip(STATISTICS, map(float, v)))}
            for (sc, seed, step), v in zip(self.frames, self.values)
        ]


def check_env_options(env_options: Any, reserved: Sequence[str], why: str) -> dict:
    """``env_options`` (None or a mapping of RoadCam options) as a new dict; refuses the
    ``reserved`` keys, which the caller sets itself (``why`` says how, and what to do)."""
    if env_options is None:
        return {}
    if not isinstance(env_options, Mapping):
        raise InvalidParameterError(
            f"env_options: expected a dict of RoadCam options, got {type(env_options).__name__}."
        )
    own = [k for k in reserved if k in env_options]
    if own:
        raise InvalidParameterError(f"env_options: {', '.join(own)} {'is' if len(own) == 1 else 'are'} {why}")
    return dict(env_options)


def _reference(reference: AppearanceReference | str | os.PathLike | None) -> AppearanceReference:
    if isinstance(reference, AppearanceReference):
        return reference
    if reference is None or isinstance(reference, (str, os.PathLike)):
        return load_reference(reference)
    raise InvalidParameterError(
        f"reference: expected an AppearanceReference, a quantile-table CSV path or None (the shipped CamVid "
        f"table), got {type(reference).__name__}."
    )


def realism_report(
    *,
    scenarios: Sequence[str] = SCENARIO_NAMES,
    seeds: Iterable[int] = REALISM_SEEDS,
    frames: int = 4,
    every: int = FRAME_EVERY,
    reference: AppearanceReference | str | os.PathLike | None = None,
    env_options: Mapping[str, Any] | None = None,
    progress: bool = False,
) -> RealismReport:
    """Render clear frames of held-out worlds and set their appearance beside a reference.

    Parameters
    ----------
    scenarios : sequence of str
        One episode per scenario and seed.
    seeds : iterable of int
        World seeds (default :data:`REALISM_SEEDS`, worlds no tuning has seen).
    frames : int
        Frames per scenario and seed, in [1, 1000]: at steps ``every``, ``2 * every``,
        ... of the ground-truth autopilot (the episode's first frame, before the car has
        driven and the auto-exposure settled, is left out).
    every : int
        Policy steps between frames, in [1, 1000].
    reference : AppearanceReference, path or None
        The real photographs' quantile tables: an object (e.g. from
        :func:`photo_reference`), a CSV file as :func:`load_reference` reads it, or
        None for the shipped CamVid table.
    env_options : dict, optional
        Further RoadCam keywords (camera size, sensor, ...), passed to every
        environment; not ``scenario``, ``noise`` or ``severity``.
    progress : bool
        Show a progress bar over the episodes.

    Returns
    -------
    RealismReport
    """
    scenarios, worlds = check_frame_protocol(scenarios=scenarios, seeds=seeds, noise="clear", severity=0.0)
    frames = check_int_in_range("frames", frames, 1, 1000)
    every = check_int_in_range("every", every, 1, 1000)
    options = check_env_options(
        env_options, _OWN_KEYS,
        "set by the report (clear frames of each of its scenarios); drop them and pass the scenarios as scenarios=.",
    )  # fmt: skip
    ref = _reference(reference)
    kept: list[tuple[str, int, int]] = []
    skipped: list[tuple[str, int, int]] = []
    values: list[list[float]] = []
    episodes = [(sc, seed) for sc in scenarios for seed in worlds]
    for sc, seed in tqdm(episodes, disable=not progress, desc="realism", unit="episode"):
        fs = collect_frames(
            scenarios=(sc,), seeds=(seed,), frames_per_seed=frames + 1, every=every, env_options=options
        )
        for rgb, road, source in list(zip(fs.images, fs.masks, fs.source))[1:]:
            stats = frame_appearance(rgb, road)
            if stats is None:
                skipped.append(source)
            else:
                kept.append(source)
                values.append([stats[s] for s in STATISTICS])
    array = np.array(values, float).reshape(len(values), len(STATISTICS))
    return RealismReport(tuple(kept), array, ref, tuple(skipped))


def photo_statistics(
    photos: str | os.PathLike,
    masks: str | os.PathLike,
    *,
    min_road_pixels: int = MIN_ROAD_PIXELS,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
) -> tuple[dict[str, np.ndarray], str]:
    """The appearance statistics of the user's own photographs, one value per photo.

    Pairs ``photos/NAME.*`` with ``masks/NAME.*`` as
    :func:`~simroad.experiments.photos.load_image_folder` does (its mask formats, and
    ``road_value``, ``road_colour``) and computes each photo's statistics
    (:func:`~simroad.metrics.appearance.frame_appearance`). Photos with fewer than
    ``min_road_pixels`` road pixels are left out. Refuses, naming ``photos`` or
    ``masks``: a folder that is missing or holds no image with a mask, masks of
    another size than their photo, masks with too little road in every photo.

    Returns
    -------
    values : dict
        ``{statistic: float array (n_photos,)}`` (NaN where a statistic has no value).
    source : str
        How many photos, from where, and how many were left out.
    """
    try:
        loaded = load_image_folder(photos, masks, road_value=road_value, road_colour=road_colour)
    except InvalidParameterError as exc:  # name the parameters of this function
        text = str(exc)
        raise InvalidParameterError(
            "photos: " + text.removeprefix("images: ") if text.startswith("images: ") else text
        ) from None
    values: dict[str, list[float]] = {s: [] for s in STATISTICS}
    largest = 0
    for rgb, road in zip(loaded.images, loaded.masks):
        largest = max(largest, int(np.count_nonzero(road)))
        stats = frame_appearance(rgb, road, min_road_pixels=min_road_pixels)
        if stats is None:
            continue
        for s in STATISTICS:
            values[s].append(stats[s])
    n, total = len(values["road_V"]), len(loaded.images)
    if n == 0:
        raise InvalidParameterError(
            f"masks: none of the {total} masks in {str(masks)!r} marks {min_road_pixels} or more road pixels "
            f"(the most is {largest}); mark the road in them or lower min_road_pixels."
        )
    left_out = f" ({total - n} left out: fewer than {min_road_pixels} road pixels)" if n < total else ""
    if not any(np.isfinite(values["road_minus_surround"])):
        raise InvalidParameterError(
            f"masks: in every photo of {str(photos)!r} the road fills the lower half, so road_minus_surround has "
            "no value; add photos showing some roadside, or mask less than the whole lower half."
        )
    return {s: np.array(v, float) for s, v in values.items()}, f"{n} photographs in {photos!s}{left_out}"


def photo_reference(
    photos: str | os.PathLike,
    masks: str | os.PathLike,
    *,
    min_road_pixels: int = MIN_ROAD_PIXELS,
    road_value: int | None = None,
    road_colour: Sequence[int] | str | None = None,
) -> AppearanceReference:
    """A reference from the user's own photographs and their road masks: the quantiles
    (:func:`~simroad.metrics.appearance.reference_from_values`) of their statistics
    (:func:`photo_statistics`, which says what it refuses)."""
    values, source = photo_statistics(
        photos, masks, min_road_pixels=min_road_pixels, road_value=road_value, road_colour=road_colour
    )
    return reference_from_values(values, source)


def _number(value: float, statistic: str) -> str:
    if not np.isfinite(value):
        return "-"
    if statistic in ("road_b", "road_a"):
        return f"{value:.1f}"
    return f"{value:.4f}" if statistic == "saturated" else f"{value:.3f}"


def format_realism_table(report: RealismReport) -> str:
    """A plain-text table: per statistic the reference's p10/median/p90, the pooled
    frames', the pooled KS distance and each scenario's."""
    scen = report.scenarios
    head = [
        "statistic",
        "ref p10",
        "ref med",
        "ref p90",
        "sim p10",
        "sim med",
        "sim p90",
        "KS",
        *(f"KS {s}" for s in scen),
    ]
    body = []
    for row in report.rows():
        s = row["statistic"]
        cells = [s, *(_number(row[k], s) for k in ("ref_p10", "ref_p50", "ref_p90", "sim_p10", "sim_p50", "sim_p90"))]
        cells += [_number(row["ks"], "ks"), *(_number(row[f"ks_{sc}"], "ks") for sc in scen)]
        body.append(cells)
    widths = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(head)]
    lines = [
        "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))
        for r in [head, *body]
    ]
    counts = ", ".join(f"{s} {sum(f[0] == s for f in report.frames)}" for s in scen)
    foot = f"{len(report.frames)} frames ({counts}); {len(report.skipped)} left out (road out of view)"
    return "\n".join(
        [*lines, foot, textwrap.fill(f"reference: {report.reference.source}", 110, subsequent_indent="  ")]
    )


def _ecdf(ax: Any, values: np.ndarray, **style: Any) -> None:
    """Draw the empirical CDF of ``values`` as steps."""
    v = np.sort(values)
    ax.step(np.r_[v[0], v], np.r_[0.0, np.arange(1, v.size + 1) / v.size], where="post", **style)


def realism_figure(report: RealismReport, path: str | os.PathLike) -> Path:
    """One panel per statistic: the reference's CDF (its quantile table, piecewise
    linear), the pooled frames' empirical CDF and each scenario's, with the KS
    distances in the legend. Writes the figure (PNG, PDF, SVG, ...) to ``path``."""
    out = check_figure_path("path", path)
    plt = start_figure(out)
    cols = 4
    rows = -(-len(STATISTICS) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 3.3 * rows), squeeze=False)
    colours = plt.get_cmap("tab10").colors
    for ax, s in zip(axes.flat, STATISTICS):
        q = report.reference.quantiles[s]
        ax.plot(q, np.linspace(0.0, 1.0, q.size), color="black", lw=2.2, ls="--", label="reference (real photographs)")
        pooled = report.sample(s)
        if pooled.size:
            _ecdf(ax, pooled, color="0.35", lw=2.2, label=f"simroad, pooled (KS {report.ks(s):.2f})")
        for k, sc in enumerate(report.scenarios):
            v = report.sample(s, sc)
            if v.size:
                _ecdf(ax, v, color=colours[k % len(colours)], lw=1.1, label=f"{sc} (KS {report.ks(s, sc):.2f})")
        ax.set_title(s, fontsize=10, fontweight="bold")
        ax.set_xlabel(UNITS[s], fontsize=8)
        ax.set_ylabel("share of frames at or below", fontsize=8)
        ax.set_ylim(0.0, 1.0)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, loc="lower right", framealpha=0.85)
    for ax in list(axes.flat)[len(STATISTICS) :]:
        ax.axis("off")
    source = textwrap.shorten(report.reference.source.split(":")[0], 110, placeholder=" ...")
    fig.suptitle(f"Appearance of {len(report.frames)} rendered clear frames (simroad) vs {source}", fontsize=10)
    save_figure(fig, out, dpi=90)
    return out


def write_realism(report: RealismReport, out: str | os.PathLike) -> dict[str, Path]:
    """Write ``realism.csv`` (one row per frame, :data:`FRAME_COLUMNS`), ``realism.json``
    (the reference's source, the frames left out and :meth:`RealismReport.rows`) and
    ``realism.png`` (:func:`realism_figure`) to the folder ``out``; return their paths."""
    check_output_dir("out", out)
    folder = ensure_writable_dir("out", out)
    paths = {"csv": folder / "realism.csv", "json": folder / "realism.json", "figure": folder / "realism.png"}
    with paths["csv"].open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=FRAME_COLUMNS)
        writer.writeheader()
        writer.writerows(report.frame_rows())
    summary = {
        "reference": report.reference.source,
        "frames": len(report.frames),
        "skipped": [list(s) for s in report.skipped],
        "statistics": [
            {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in r.items()}
            for r in report.rows()
        ],
    }
    paths["json"].write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    realism_figure(report, paths["figure"])
    return paths
