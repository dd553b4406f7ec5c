"""Build a sweep's report from ``results.jsonl`` alone, never changing it (``simroad report DIR``).

``summary.csv`` / ``summary.json``
    One row per scenario x noise x severity x filters x driver: the number of
    episodes, failed episodes, and mean with 95 % confidence half-width (Student t
    over seeds; the ``*_ci95`` columns) of FNR, FPR, IoU, off-road fraction,
    collision rate, lateral RMSE and driving score. The JSON file holds the same
    rows as a list of objects (NaN where no episode had a finite value).
``summary.md``
    The same table for people, under an at-a-glance table per noise and severity
    (:func:`headline`), and a list of the lines of ``results.jsonl`` not used (if any).
``error_rates.png``
    The paper's Fig. 7a done properly: pooled-per-episode FNR and FPR per noise, one
    bar per filter set, with 95 % confidence intervals.
``safety.png``
    Off-road fraction and driving score against severity, per noise: detector without
    filters, with all filters, and the oracle.
"""

from __future__ import annotations

import csv
import json
import math
import os
import sys
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

import numpy as np

from simroad._validation import SimroadError
from simroad.experiments.results import RESULTS_NAME, BadLine, read_results

__all__ = ["METRICS", "build_report", "headline", "summarise"]

#: Summary column -> record key (collision rate is the mean of ``collided``).
METRICS = {
    "fnr": "fnr",
    "fpr": "fpr",
    "iou": "iou",
    "offroad_fraction": "offroad_fraction",
    "collision_rate": "collided",
    "lateral_rmse_m": "lateral_rmse_m",
    "driving_score": "driving_score",
}
_GROUP = ("scenario", "noise", "severity", "filters", "driver", "detector")
_ALL = "shadow+rain_snow+light"


def _detectors(records: list[dict]) -> list[str]:
    """The detectors that drove (by name), in a fixed order, ``paper`` first."""
    return sorted(
        {r.get("detector", "") for r in records if r["driver"] == "detector"}, key=lambda d: (d != "paper", d)
    )


def _setting(detector: str, filters: str, many: bool) -> str:
    """A perception setting's label: its filter set, and its detector when a sweep has several."""
    short = "all" if filters == _ALL else filters
    return f"{detector}: {short}" if many else short


def _mean_ci(values: list[float]) -> tuple[float, float]:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if len(v) == 0:
        return math.nan, math.nan
    if len(v) == 1:
        return float(v[0]), math.nan
    from scipy import stats

    half = float(stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v)))
    return float(v.mean()), half


def summarise(records: list[dict]) -> list[dict]:
    """Aggregate episode records into one row per grid cell group."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        groups[tuple(r[k] for k in _GROUP)].append(r)
    rows = []
    for key in sorted(groups, key=lambda k: tuple(str(x) for x in k)):
        recs = groups[key]
        ok = [r for r in recs if not r.get("error")]
        row = dict(zip(_GROUP, key))
        row["episodes"] = len(recs)
        row["failed"] = len(recs) - len(ok)
        for col, src in METRICS.items():
            mean, half = _mean_ci([float(r[src]) for r in ok])
            row[col] = mean
            row[f"{col}_ci95"] = half
        rows.append(row)
    return rows


def _write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _fmt(mean: float, half: float, pct: bool) -> str:
    if not math.isfinite(mean):
        return "–"
    k = 100.0 if pct else 1.0
    text = f"{mean * k:.2f}" if pct else f"{mean:.3f}"
    return text + (
        f" ± {half * k:.2f}" if pct and math.isfinite(half) else f" ± {half:.3f}" if math.isfinite(half) else ""
    )


def _write_md(rows: list[dict], path: Path) -> None:
    cols = ["scenario", "noise", "severity", "detector", "filters", "driver", "episodes"]
    head = cols + ["FNR %", "FPR %", "IoU", "off-road %", "collision %", "lat. RMSE m", "driving score"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [str(r[c]) for c in cols]
        cells += [
            _fmt(r["fnr"], r["fnr_ci95"], True),
            _fmt(r["fpr"], r["fpr_ci95"], True),
            _fmt(r["iou"], r["iou_ci95"], False),
            _fmt(r["offroad_fraction"], r["offroad_fraction_ci95"], True),
            _fmt(r["collision_rate"], r["collision_rate_ci95"], True),
            _fmt(r["lateral_rmse_m"], r["lateral_rmse_m_ci95"], False),
            _fmt(r["driving_score"], r["driving_score_ci95"], False),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    text = (
        "# Ablation summary\n\nMean ± 95 % confidence half-width over seeds (Student t).\n\n" + "\n".join(lines) + "\n"
    )
    path.write_text(text)


def _write_md_with_headline(records: list[dict], rows: list[dict], path: Path) -> None:
    _write_md(rows, path)
    body = path.read_text().split("\n", 2)[2]
    intro = (
        "# Ablation summary\n\n## At a glance (means over scenarios and seeds)\n\n"
        + headline(records)
        + "\n\n## Per cell\n"
    )
    path.write_text(intro + body)


def headline(records: list[dict]) -> str:
    """A compact markdown table: per noise and severity (pooled over scenarios and
    seeds), FNR / FPR for every filter set, and off-road fraction and driving score for
    no filters, all filters and the oracle."""
    ok = [r for r in records if not r.get("error")]
    cells = sorted({(r["noise"], r["severity"]) for r in ok}, key=lambda c: (c[0] != "clear", c[0], c[1]))
    filters = sorted(
        {r["filters"] for r in ok if r["driver"] == "detector"},
        key=lambda f: (f != "none", f == _ALL, f),
    )
    dets = _detectors(ok)
    many = len(dets) > 1
    settings = [(d, f) for d in dets for f in filters]
    head = ["noise", "severity"] + [f"FNR / FPR % ({_setting(d, f, many)})" for d, f in settings]
    pairs = [(d, f) for d in dets for f in ("none", _ALL)]
    names = " / ".join([_setting(d, f, many) for d, f in pairs] + ["oracle"])
    head += [f"off-road % ({names})", f"driving score ({names})"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for noise, sev in cells:
        rs = [r for r in ok if r["noise"] == noise and r["severity"] == sev]
        row = [noise, f"{sev:g}"]
        for d, f in settings:
            det = [r for r in rs if r["driver"] == "detector" and r.get("detector", "") == d and r["filters"] == f]
            row.append(
                f"{100 * np.mean([r['fnr'] for r in det]):.1f} / {100 * np.mean([r['fpr'] for r in det]):.1f}"
                if det
                else "–"
            )
        groups = [
            [r for r in rs if r["driver"] == "detector" and r.get("detector", "") == d and r["filters"] == f]
            for d, f in pairs
        ] + [[r for r in rs if r["driver"] == "oracle"]]
        row.append(" / ".join(f"{100 * np.mean([r['offroad_fraction'] for r in g]):.1f}" if g else "–" for g in groups))
        row.append(" / ".join(f"{np.mean([r['driving_score'] for r in g]):.2f}" if g else "–" for g in groups))
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def _error_rates_figure(records: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    det = [r for r in records if r["driver"] == "detector" and not r.get("error")]
    noises = sorted({r["noise"] for r in det}, key=lambda n: (n != "clear", n))
    filters = sorted({r["filters"] for r in det}, key=lambda f: (f != "none", f == _ALL, f))
    dets = _detectors(det)
    settings = [(d, f) for d in dets for f in filters]
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), sharey=False)
    width = 0.8 / max(1, len(settings))
    for ax, metric in zip(axes, ("fnr", "fpr")):
        for j, (d, f) in enumerate(settings):
            stats = [
                _mean_ci(
                    [
                        100 * r[metric]
                        for r in det
                        if r["noise"] == n and r["filters"] == f and r.get("detector", "") == d
                    ]
                )
                for n in noises
            ]
            means = [m for m, _ in stats]
            errs = [h if math.isfinite(h) else 0.0 for _, h in stats]
            xs = np.arange(len(noises)) + (j - (len(settings) - 1) / 2) * width
            label = f"filters: {f}" if len(dets) == 1 else f"{d}, filters: {f}"
            ax.bar(xs, means, width, yerr=errs, capsize=3, label=label)
        ax.set_xticks(np.arange(len(noises)), noises, rotation=20)
        ax.set_ylabel(f"{metric.upper()} (%)")
        ax.set_title(f"{metric.upper()} per noise (mean, 95 % CI)")
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _safety_figure(records: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in records if not r.get("error")]
    noises = sorted({r["noise"] for r in ok if r["noise"] != "clear"}) or ["clear"]
    clear = [r for r in ok if r["noise"] == "clear"]
    dets = _detectors(ok)

    def chooser(d: str, f: str) -> Callable[[dict], bool]:
        return lambda r: r["driver"] == "detector" and r.get("detector", "") == d and r["filters"] == f

    lines = [
        (f"{'detector' if len(dets) == 1 else d}, {label}", chooser(d, f))
        for d in dets
        for f, label in (("none", "no filters"), (_ALL, "all filters"))
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
                stats = [_mean_ci([r[metric] for r in rs if pick(r) and r["severity"] == s]) for s in sevs]
                if all(not math.isfinite(m) for m, _ in stats):
                    continue
                ax.errorbar(
                    sevs,
                    [m for m, _ in stats],
                    yerr=[h if math.isfinite(h) else 0 for _, h in stats],
                    marker="o",
                    capsize=3,
                    label=name,
                )
            ax.set_xlabel("severity")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            if row == 0:
                ax.set_title(noise)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _write_bad_lines(bad: list[BadLine], path: Path) -> None:
    """Append the lines that were not used to summary.md."""
    lines = [f"- {b}" for b in bad]
    text = f"\n## Lines of {RESULTS_NAME} not used ({len(bad)})\n\n" + "\n".join(lines) + "\n"
    with open(path, "a") as fh:
        fh.write(text)


def build_report(directory: str | os.PathLike, *, log: Callable[[str], None] | None = None) -> dict[str, Path]:
    """Rebuild the report files of the sweep in ``directory`` from its results.jsonl.

    ``results.jsonl`` is only read, never changed. Every line that is not a valid row
    (:func:`~simroad.experiments.results.check_row`: not JSON, torn, a wrong type, a
    missing key, a second row of one cell) stays out of the summary and is named —
    line number and why — through ``log`` and in ``summary.md``.

    Parameters
    ----------
    directory : path
        A sweep's output directory (holding ``results.jsonl``).
    log : callable, optional
        Receives one message per line not used (default: print to stderr).

    Returns
    -------
    dict of str to Path
        File name -> path of each file written: ``summary.csv``, ``summary.json``,
        ``summary.md``, ``error_rates.png`` and ``safety.png`` (see the module
        docstring for their contents).
    """
    d = Path(directory)
    path = d / RESULTS_NAME
    if not path.exists():
        raise SimroadError(f"dir: no {RESULTS_NAME} in {str(d)!r}; run 'simroad ablate --out {d}' first.")
    records, bad = read_results(path)
    say = log or (lambda message: print(message, file=sys.stderr))
    for b in bad:
        say(f"{path}: {b}; not used")
    if not records:
        raise SimroadError(f"dir: {str(path)!r} holds no finished episode yet ({len(bad)} line(s) not usable).")
    rows = summarise(records)
    out = {name: d / name for name in ("summary.csv", "summary.json", "summary.md", "error_rates.png", "safety.png")}
    _write_csv(rows, out["summary.csv"])
    out["summary.json"].write_text(json.dumps(rows, indent=1, default=str))
    _write_md_with_headline(records, rows, out["summary.md"])
    if bad:
        _write_bad_lines(bad, out["summary.md"])
    _error_rates_figure(records, out["error_rates.png"])
    _safety_figure(records, out["safety.png"])
    return out
