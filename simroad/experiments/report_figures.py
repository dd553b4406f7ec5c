"""A sweep report's figures, with the intervals of :mod:`simroad.experiments.stats`.

``error_rates.png``
    The paper's Fig. 7a done properly: FNR and FPR on the ground pixels and FPR on the
    whole image, per noise, one bar per filter set (and detector), mean over episodes
    with its bootstrap interval as asymmetric error bars.
``safety.png``
    Off-road fraction and driving score against severity, per noise: the detector
    without filters, with all filters, and the oracle; mean with bootstrap interval.
``paired.png``
    Per noise x severity, the paired driving-score difference of each filter set (all
    filters first) minus no filters in the same worlds and seeds, with the interval of
    the paired difference, and a zero line: a point above zero means the filters helped.

Points without an interval (one episode or one pair) are drawn without error bars.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from simroad.experiments._plotting import pyplot, save_figure
from simroad.experiments.stats import ALL_FILTERS, detectors, filter_order, mean_interval

__all__ = ["error_rates_figure", "paired_figure", "safety_figure"]


def _yerr(stats: Sequence[tuple[float, float, float]], scale: float = 1.0) -> np.ndarray:
    """Asymmetric error bars (2, n) from (mean, lo, hi); 0 where there is no interval."""
    below = [(m - lo) * scale if math.isfinite(lo) and math.isfinite(m) else 0.0 for m, lo, _ in stats]
    above = [(hi - m) * scale if math.isfinite(hi) and math.isfinite(m) else 0.0 for m, _, hi in stats]
    return np.maximum(np.array([below, above]), 0.0)


def _save(fig: Any, path: Path) -> None:
    save_figure(fig, path, dpi=90, metadata={"Software": None})  # no version: the same results, the same bytes


def error_rates_figure(records: list[dict], path: Path) -> None:
    """Write ``error_rates.png`` (see the module docstring)."""
    plt = pyplot()
    det = [r for r in records if r["driver"] == "detector" and not r.get("error")]
    noises = sorted({r["noise"] for r in det}, key=lambda n: (n != "clear", n))
    filters = filter_order(r["filters"] for r in det)
    dets = detectors(det)
    settings = [(d, f) for d in dets for f in filters]
    panels = (("fnr", "FNR, ground"), ("fpr", "FPR, ground"), ("fpr_image", "FPR, whole image"))
    fig, axes = plt.subplots(1, len(panels), figsize=(15, 3.8))
    width = 0.8 / max(1, len(settings))
    for ax, (metric, title) in zip(axes, panels):
        for j, (d, f) in enumerate(settings):
            stats = [
                mean_interval(
                    r[metric] for r in det if r["noise"] == n and r["filters"] == f and r.get("detector", "") == d
                )
                for n in noises
            ]
            xs = np.arange(len(noises)) + (j - (len(settings) - 1) / 2) * width
            label = f"filters: {f}" if len(dets) == 1 else f"{d}, filters: {f}"
            ax.bar(xs, [100 * m for m, _, _ in stats], width, yerr=_yerr(stats, 100), capsize=3, label=label)
        if not any(math.isfinite(float(r[metric])) for r in det):
            ax.text(0.5, 0.5, f"no finite {metric} in these records", ha="center", transform=ax.transAxes)
        ax.set_xticks(np.arange(len(noises)), noises, rotation=20)
        ax.set_ylabel(f"{metric.split('_')[0].upper()} (%)")
        ax.set_title(f"{title} (mean, 95 % bootstrap CI)", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8)
    _save(fig, path)


def safety_figure(records: list[dict], path: Path) -> None:
    """Write ``safety.png`` (see the module docstring)."""
    plt = pyplot()
    ok = [r for r in records if not r.get("error")]
    noises = sorted({r["noise"] for r in ok if r["noise"] != "clear"}) or ["clear"]
    clear = [r for r in ok if r["noise"] == "clear"]
    dets = detectors(ok)

    def chooser(d: str, f: str) -> Callable[[dict], bool]:
        return lambda r: r["driver"] == "detector" and r.get("detector", "") == d and r["filters"] == f

    lines = [
        (f"{'detector' if len(dets) == 1 else d}, {label}", chooser(d, f))
        for d in dets
        for f, label in (("none", "no filters"), (ALL_FILTERS, "all filters"))
    ] + [("oracle", lambda r: r["driver"] == "oracle")]
    fig, axes = plt.subplots(2, len(noises), figsize=(3.2 * len(noises), 5.5), squeeze=False)
    for col, noise in enumerate(noises):
        rs = [r for r in ok if r["noise"] == noise] + clear
        sevs = sorted({r["severity"] for r in rs})
        for row, (metric, label) in enumerate(
            (("offroad_fraction", "off-road fraction"), ("driving_score", "driving score"))
        ):
            ax = axes[row][col]
            for name, pick in lines:
                stats = [mean_interval(r[metric] for r in rs if pick(r) and r["severity"] == s) for s in sevs]
                if all(not math.isfinite(m) for m, _, _ in stats):
                    continue
                ax.errorbar(sevs, [m for m, _, _ in stats], yerr=_yerr(stats), marker="o", capsize=3, label=name)
            ax.set_xlabel("severity")
            ax.set_ylabel(label)
            ax.set_ylim(-0.03, 1.03)
            ax.grid(alpha=0.3)
            if row == 0:
                ax.set_title(noise)
    axes[0][0].legend(fontsize=7)
    _save(fig, path)


def paired_figure(paired: list[dict], path: Path) -> None:
    """Write ``paired.png`` from :func:`~simroad.experiments.stats.paired_differences` rows."""
    plt = pyplot()
    rows = [p for p in paired if p["scenario"] == "all" and p["setting"] != "oracle"]
    dets = sorted({p["detector"] for p in rows}, key=lambda d: (d != "paper", d)) or [""]
    cells = sorted({(p["noise"], p["severity"]) for p in rows}, key=lambda c: (c[0] != "clear", c[0], c[1]))
    fig, axes = plt.subplots(len(dets), 1, figsize=(max(6.0, 0.55 * len(cells) + 2.5), 3.6 * len(dets)), squeeze=False)
    for ax, det in zip(axes[:, 0], dets):
        mine = [p for p in rows if p["detector"] == det]
        settings = sorted({p["setting"] for p in mine}, key=lambda f: (f != ALL_FILTERS, f))
        versus = any(p.get("comparison") == "detectors" for p in mine)
        width = 0.8 / max(1, len(settings))
        for j, setting in enumerate(settings):
            found = {(p["noise"], p["severity"]): p for p in rows if p["detector"] == det and p["setting"] == setting}
            stats = [
                (found[c]["driving_score_diff"], found[c]["driving_score_diff_lo"], found[c]["driving_score_diff_hi"])
                if c in found
                else (math.nan, math.nan, math.nan)
                for c in cells
            ]
            xs = np.arange(len(cells)) + (j - (len(settings) - 1) / 2) * width
            label = "all filters" if setting == ALL_FILTERS else ("no filters" if setting == "none" else setting)
            style = {"marker": "o", "markersize": 6} if setting == ALL_FILTERS else {"marker": ".", "alpha": 0.8}
            ax.errorbar(xs, [m for m, _, _ in stats], yerr=_yerr(stats), ls="none", capsize=2, label=label, **style)
        ax.axhline(0.0, color="black", lw=0.8)
        ax.set_xticks(np.arange(len(cells)), [f"{n} {s:g}" if n != "clear" else n for n, s in cells], rotation=30)
        if versus:
            ax.set_ylabel("Δ driving score")
            ax.set_title(f"{det}, same filters: paired by world and seed (mean, 95 % CI)", fontsize=10)
        else:
            ax.set_ylabel("Δ driving score vs none")
            title = "filters − none, paired by world and seed (mean, 95 % CI)"
            ax.set_title(f"{det}: {title}" if len(dets) > 1 else title, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        if settings:
            ax.legend(fontsize=7, ncol=2)
        else:  # e.g. --filters none: no filter set to pair with no filters
            ax.text(0.5, 0.5, "no paired comparison in this sweep:\nadd a filter set (e.g. --filters none,all)",
                    ha="center", va="center", transform=ax.transAxes)  # fmt: skip
    _save(fig, path)
