"""Build a sweep's report from ``results.jsonl`` alone, never changing it (``simroad report DIR``).

Intervals are 95 % (see :mod:`simroad.experiments.stats`): percentile bootstrap of the
mean over episodes (9999 resamples, seed 0) for every mean, exact Clopper-Pearson for
the collision rate; they stay inside each quantity's range. One episode gives no
interval (``_lo``/``_hi`` NaN, shown ``(n=1)``); equal values give ``lo = hi = mean``.
The same ``results.jsonl`` gives the same files, byte for byte.

``summary.csv`` / ``summary.json``
    One row per scenario x noise x severity x filters x driver x detector: the number
    of episodes, failed episodes, and for each column of :data:`METRICS` the mean (or
    rate) with its interval (``<column>_lo``, ``<column>_hi``). ``fnr``/``fpr`` count
    the ground pixels, ``fnr_image``/``fpr_image`` every pixel (sky = non-road);
    ``fpr_image_minus_ground`` is the mean per-episode ``fpr_image - fpr`` (a mask
    that calls the sky road makes it positive). The JSON file holds the same rows as
    a list of objects (NaN where no episode had a finite value).
``summary.md``
    An at-a-glance table per noise and severity (:func:`headline`), the paired
    comparison of filters against none, and the per-cell table as ``mean [lo, hi]``;
    then the lines of ``results.jsonl`` not used (if any).
``paired.csv`` / ``paired.json``
    :func:`~simroad.experiments.stats.paired_differences`: every filter set (and the
    oracle) minus no filters in the same worlds and seeds, per detector, noise and
    severity, pooled over scenarios (``scenario`` ``all``) and per scenario.
``error_rates.png``, ``safety.png``, ``paired.png``
    See :mod:`simroad.experiments.report_figures`.
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

from simroad.core.validation import check_input_dir, check_input_file, ensure_writable_dir
from simroad.errors import InvalidParameterError
from simroad.experiments.report_figures import error_rates_figure, paired_figure, safety_figure
from simroad.experiments.results import (
    RESULTS_NAME,
    BadLine,
    check_merge_target,
    grid_steps,
    merge_results,
    read_results,
    write_merged,
)
from simroad.experiments.stats import (
    ALL_FILTERS,
    detectors,
    filter_order,
    head_to_head_label,
    mean_interval,
    paired_differences,
    proportion_interval,
)

__all__ = ["METRICS", "build_report", "failed_components", "headline", "summarise"]

#: Summary column -> record key (collision rate is the rate of ``collided``).
METRICS = {
    "fnr": "fnr",
    "fpr": "fpr",
    "fnr_image": "fnr_image",
    "fpr_image": "fpr_image",
    "iou": "iou",
    "offroad_fraction": "offroad_fraction",
    "collision_rate": "collided",
    "lateral_rmse_m": "lateral_rmse_m",
    "mean_speed_m_s": "mean_speed_m_s",
    "start_speed_m_s": "start_speed_m_s",
    "slide_steps": "slide_steps",
    "driving_score": "driving_score",
}
#: The derived column: per-episode whole-image FPR minus ground FPR.
SKY_COLUMN = "fpr_image_minus_ground"
_GROUP = ("scenario", "noise", "severity", "filters", "driver", "detector")
_FILES = (
    "summary.csv", "summary.json", "summary.md", "paired.csv", "paired.json",
    "error_rates.png", "safety.png", "paired.png",
)  # fmt: skip


def _setting(detector: str, filters: str, many: bool) -> str:
    """A perception setting's label: its filter set, and its detector when a sweep has several."""
    short = "all" if filters == ALL_FILTERS else filters
    return f"{detector}: {short}" if many else short


def _sky_excess(r: dict) -> float:
    return float(r["fpr_image"]) - float(r["fpr"])


def summarise(records: list[dict]) -> list[dict]:
    """Aggregate episode records into one row per grid cell group (columns in the module docstring)."""
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
            values = [r.get(src) for r in ok]  # None (left out) where a row predates the key
            row[col], row[f"{col}_lo"], row[f"{col}_hi"] = (
                proportion_interval(values) if col == "collision_rate" else mean_interval(values)
            )
        row[SKY_COLUMN], row[f"{SKY_COLUMN}_lo"], row[f"{SKY_COLUMN}_hi"] = mean_interval(map(_sky_excess, ok))
        rows.append(row)
    return rows


def _write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else [])
        w.writeheader()
        w.writerows(rows)


def _fmt(mean: float, lo: float, hi: float, scale: float = 1.0, digits: int = 3) -> str:
    """``mean [lo, hi]`` times ``scale``; ``mean (n=1)`` without an interval; ``–`` without a mean."""
    if not math.isfinite(mean):
        return "–"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{mean * scale:.{digits}f} (n=1)"
    return f"{mean * scale:.{digits}f} [{lo * scale:.{digits}f}, {hi * scale:.{digits}f}]"


#: Per-cell table: column -> (heading, scale, digits).
_MD_COLUMNS = {
    "fnr": ("FNR %", 100, 2),
    "fpr": ("FPR %", 100, 2),
    "fnr_image": ("whole-image FNR %", 100, 2),
    "fpr_image": ("whole-image FPR %", 100, 2),
    SKY_COLUMN: ("whole − ground FPR, pts", 100, 2),
    "iou": ("IoU", 1, 3),
    "offroad_fraction": ("off-road %", 100, 2),
    "collision_rate": ("collision %", 100, 1),
    "lateral_rmse_m": ("lat. RMSE m", 1, 3),
    "mean_speed_m_s": ("speed m/s", 1, 2),
    "start_speed_m_s": ("start m/s", 1, 2),
    "slide_steps": ("slide steps", 1, 1),
    "driving_score": ("driving score", 1, 3),
}


def _cell(row: dict, col: str, scale: float, digits: int) -> str:
    return _fmt(row[col], row[f"{col}_lo"], row[f"{col}_hi"], scale, digits)


def _cell_table(rows: list[dict]) -> str:
    cols = ["scenario", "noise", "severity", "detector", "filters", "driver", "episodes"]
    head = cols + [h for h, _, _ in _MD_COLUMNS.values()]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [str(r[c]) for c in cols] + [_cell(r, c, s, d) for c, (_, s, d) in _MD_COLUMNS.items()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _paired_table(paired: list[dict], *, head_to_head: bool = False) -> str:
    """The pooled (``scenario`` ``all``) paired rows as markdown: filter sets and the
    oracle against none, or (``head_to_head``) detector against detector."""
    rows = [p for p in paired if p["scenario"] == "all" and (p.get("comparison") == "detectors") == head_to_head]
    if not rows:
        return "(nothing to pair in this sweep: " + (
            "one detector ran)" if head_to_head else "no filter set or oracle beside no filters)"
        )
    many = head_to_head or len({p["detector"] for p in rows}) > 1
    head = (["detectors" if head_to_head else "detector"] if many else []) + ["noise", "severity"]
    head += ["filters" if head_to_head else "setting − none", "pairs"]
    head += ["Δ driving score", "Δ off-road, pts", "Δ FNR, pts", "Δ FPR, pts"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for p in rows:
        setting = "all filters" if p["setting"] == ALL_FILTERS else p["setting"]
        cells = ([p["detector"]] if many else []) + [p["noise"], f"{p['severity']:g}", setting, str(p["pairs"])]
        cells.append(_fmt(p["driving_score_diff"], p["driving_score_diff_lo"], p["driving_score_diff_hi"]))
        for m in ("offroad_fraction", "fnr", "fpr"):
            cells.append(_fmt(p[f"{m}_diff"], p[f"{m}_diff_lo"], p[f"{m}_diff_hi"], 100, 2))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _write_md(records: list[dict], rows: list[dict], paired: list[dict], path: Path) -> None:
    text = (
        "# Ablation summary\n\n"
        "Intervals are 95 %: percentile bootstrap of the mean over episodes (9999 resamples, "
        "seed 0); Clopper-Pearson for collision rates; `(n=1)`: one episode, no interval. "
        "FNR/FPR count the ground pixels, whole-image FNR/FPR every pixel (the sky is non-road).\n\n"
        "## At a glance (means over scenarios and seeds)\n\n" + headline(records, paired=paired) + "\n\n"
        "## Filters vs none, paired\n\n"
        "Mean difference setting − none over pairs of episodes in the same world and seed "
        "(scenario, seed), pooled over scenarios, with the bootstrap interval of the paired "
        "difference (resampling pairs). Per scenario: `paired.csv`.\n\n"
        + _paired_table(paired)
        + "\n\n"
        + _head_to_head_section(paired)
        + "## Per cell\n\nMean [95 % interval] over seeds.\n\n"
        + _cell_table(rows)
        + "\n"
    )
    path.write_text(text)


def _head_to_head_section(paired: list[dict]) -> str:
    """The detector-vs-detector section of summary.md (empty with one detector)."""
    if not any(p.get("comparison") == "detectors" for p in paired):
        return ""
    return (
        "## Detector vs detector, paired\n\n"
        "Mean difference detector − the first detector (`paper` when it ran) at the same filter set, over pairs "
        "of episodes in the same world and seed, pooled over scenarios, with the bootstrap interval of the "
        "paired difference. Per scenario: `paired.csv`.\n\n" + _paired_table(paired, head_to_head=True) + "\n\n"
    )


def _mean(rs: list[dict], key: str) -> float:
    v = [float(r[key]) for r in rs if math.isfinite(float(r[key]))]
    return float(np.mean(v)) if v else math.nan


def _pct(x: float, digits: int = 1) -> str:
    return f"{100 * x:.{digits}f}" if math.isfinite(x) else "–"


def headline(records: list[dict], *, paired: list[dict] | None = None) -> str:
    """A compact markdown table: per noise and severity (pooled over scenarios and
    seeds), FNR / FPR for every filter set; off-road fraction, driving score, route
    completion, mean speed and slide steps for no filters, all filters and the oracle; the worst
    whole-image minus ground FPR over the detector's settings (points); the paired
    all-filters − none driving-score difference with its interval, per detector, and
    each detector − the first per filter set (``paired`` as
    :func:`~simroad.experiments.stats.paired_differences` gives it; computed when None).
    Only the filter sets the sweep ran get columns."""
    ok = [r for r in records if not r.get("error")]
    paired = paired_differences(ok) if paired is None else paired
    cells = sorted({(r["noise"], r["severity"]) for r in ok}, key=lambda c: (c[0] != "clear", c[0], c[1]))
    filters = filter_order(r["filters"] for r in ok if r["driver"] == "detector")
    dets = detectors(ok)
    many = len(dets) > 1
    settings = [(d, f) for d in dets for f in filters]
    head = ["noise", "severity"] + [f"FNR / FPR % ({_setting(d, f, many)})" for d, f in settings]
    shown = [f for f in ("none", ALL_FILTERS) if f in filters]  # the settings a sweep ran, no empty columns
    pairs = [(d, f) for d in dets for f in shown]
    names = " / ".join([_setting(d, f, many) for d, f in pairs] + ["oracle"])
    head += [f"off-road % ({names})", f"driving score ({names})", f"route completion % ({names})"]
    head += [f"mean speed m/s ({names})", f"slide steps ({names})", "max whole − ground FPR, pts"]
    # paired columns: all filters − none per detector, each detector − the first per shown filter set
    compared = [(d, ALL_FILTERS, "all − none" + (f" ({d})" if many else "")) for d in dets if ALL_FILTERS in shown]
    compared += [(head_to_head_label(d, dets[0]), f, f"{head_to_head_label(d, dets[0])} ({_setting('', f, False)})")
                 for d in dets[1:] for f in shown]  # fmt: skip
    head += [f"driving score {name}, paired" for _, _, name in compared]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for noise, sev in cells:
        rs = [r for r in ok if r["noise"] == noise and r["severity"] == sev]
        row = [noise, f"{sev:g}", *_headline_cells(rs, settings, pairs)]
        for d, setting, _ in compared:
            want = (d, noise, sev, "all", setting)
            p = next((p for p in paired if tuple(p[k] for k in _PAIRED_ID) == want), None)
            diff = (p["driving_score_diff"], p["driving_score_diff_lo"], p["driving_score_diff_hi"]) if p else None
            row.append(f"{_fmt(*diff)} ({p['pairs']} pairs)" if p and diff else "–")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


_PAIRED_ID = ("detector", "noise", "severity", "scenario", "setting")


def _headline_cells(rs: list[dict], settings: list[tuple[str, str]], pairs: list[tuple[str, str]]) -> list[str]:
    """One noise x severity of :func:`headline`: FNR / FPR per setting; off-road,
    driving score, route completion, mean speed and slide steps of ``pairs`` and the oracle (why a
    score moved: a car that crawls stays on the road and completes little); the worst
    whole-image minus ground FPR."""

    def pick(d: str, f: str) -> list[dict]:
        return [r for r in rs if r["driver"] == "detector" and r.get("detector", "") == d and r["filters"] == f]

    cells = []
    for d, f in settings:
        det = pick(d, f)
        cells.append(f"{_pct(_mean(det, 'fnr'))} / {_pct(_mean(det, 'fpr'))}" if det else "–")
    groups = [pick(d, f) for d, f in pairs] + [[r for r in rs if r["driver"] == "oracle"]]
    cells.append(" / ".join(_pct(_mean(g, "offroad_fraction")) if g else "–" for g in groups))
    cells.append(" / ".join(f"{_mean(g, 'driving_score'):.2f}" if g else "–" for g in groups))
    cells.append(" / ".join(_pct(_mean(g, "route_completion"), 0) if g else "–" for g in groups))
    cells.append(" / ".join(f"{_mean(g, 'mean_speed_m_s'):.1f}" if g else "–" for g in groups))
    cells.append(" / ".join(f"{_mean(g, 'slide_steps'):.1f}" if g else "–" for g in groups))
    sky = [_mean(det, "fpr_image") - _mean(det, "fpr") for det in (pick(d, f) for d, f in settings) if det]
    sky = [x for x in sky if math.isfinite(x)]
    cells.append(_pct(max(sky), 2) if sky else "–")
    return cells


def failed_components(records: list[dict]) -> list[dict]:
    """The failed episodes grouped by what drove them: one dict per detector spec (or
    ``oracle``) and filter set with ``failed``, ``episodes`` (of that group), ``cells``
    (scenario/noise/severity/seed of each failed one) and ``error`` (the first line of
    the first failure's message)."""
    groups: dict[tuple[str, str], dict] = {}
    for r in records:
        who = r.get("detector_spec") or r.get("detector") or r.get("driver", "")
        g = groups.setdefault((str(who), str(r.get("filters", ""))), {"episodes": 0, "failed": 0, "cells": []})
        g["episodes"] += 1
        if r.get("error"):
            g["failed"] += 1
            g["cells"].append(f"{r['scenario']}/{r['noise']}/{r['severity']:g}/seed {r['seed']}")
            g.setdefault("error", str(r["error"]).splitlines()[0])
    return [{"driver": k[0], "filters": k[1], **g} for k, g in groups.items() if g["failed"]]


def _write_failed(records: list[dict], path: Path) -> None:
    """Append the failed episodes, by detector and filter set, to summary.md."""
    failed = failed_components(records)
    if not failed:
        return
    total = sum(f["failed"] for f in failed)
    lines = [f"\n## Failed episodes ({total})\n"]
    for f in failed:
        every = " (every one)" if f["failed"] == f["episodes"] else ""
        cells = ", ".join(f["cells"][:10]) + (f" and {len(f['cells']) - 10} more" if len(f["cells"]) > 10 else "")
        lines.append(f"- **{f['driver']}**, filters {f['filters']}: {f['failed']} of {f['episodes']} failed{every} — "
                     f"{cells}. First error: `{f['error']}`")  # fmt: skip
    with open(path, "a") as fh:
        fh.write("\n".join(lines) + "\n")


def _write_bad_lines(bad: list[BadLine], path: Path) -> None:
    """Append the lines that were not used to summary.md."""
    lines = [f"- {b}" for b in bad]
    text = f"\n## Lines of {RESULTS_NAME} not used ({len(bad)})\n\n" + "\n".join(lines) + "\n"
    with open(path, "a") as fh:
        fh.write(text)


def build_report(
    directory: str | os.PathLike,
    *more: str | os.PathLike,
    out: str | os.PathLike | None = None,
    log: Callable[[str], None] | None = None,
) -> dict[str, Path]:
    """Build the report of the sweep in ``directory`` (and of more sweeps) from their results.jsonl.

    Every ``results.jsonl`` is only read, never changed. Every line that is not a valid
    row (:func:`~simroad.experiments.results.check_row`: not JSON, torn, a wrong type,
    a missing key, a second row of one cell, in one file or across files) stays out of
    the summary and is named — file, line number and why — through ``log`` and in
    ``summary.md``. Rows of different step budgets are different cells; when the rows
    hold more than one budget, each scenario is reported per budget (``racetrack (150
    steps)``), so episodes of different lengths are neither pooled nor paired.

    Parameters
    ----------
    directory, *more : path
        Sweep output directories (each holding ``results.jsonl``).
    out : path, optional
        Where the report goes: by default ``directory`` itself (one sweep). A report
        over several sweeps needs a folder of its own; it also receives the rows used
        (``results.jsonl``, so ``simroad report OUT`` rebuilds it) and ``sources.json``
        (each source and how many of its rows were used). A folder holding a sweep's
        own results is refused.
    log : callable, optional
        Receives one message per line not used (default: print to stderr).

    Returns
    -------
    dict of str to Path
        File name -> path of each file written: ``summary.csv``, ``summary.json``,
        ``summary.md``, ``paired.csv``, ``paired.json``, ``error_rates.png``,
        ``safety.png`` and ``paired.png`` (see the module docstring for their contents),
        plus ``results.jsonl`` and ``sources.json`` when ``out`` is not ``directory``.
    """
    sources = [_source(d) for d in (directory, *more)]
    target = sources[0] if out is None else ensure_writable_dir("out", out)
    merged = target.resolve() != sources[0].resolve() or len(sources) > 1
    if out is None and len(sources) > 1:
        raise InvalidParameterError(
            f"out: a report over {len(sources)} sweeps needs a folder of its own; pass out= (--out) a new folder."
        )
    if merged:
        check_merge_target(target, sources)
    used: dict[str, int] = {}
    try:
        if merged:
            records, bad, used = merge_results(sources)
        else:
            records, bad = read_results(sources[0] / RESULTS_NAME, default_budget=grid_steps(sources[0]))
    except OSError as exc:
        raise InvalidParameterError(f"dir: cannot read {exc.filename!r} ({exc.strerror or exc}).") from None
    say = log or (lambda message: print(message, file=sys.stderr))
    for b in bad:
        say(f"{b}; not used" if b.source else f"{sources[0] / RESULTS_NAME}: {b}; not used")
    if not records:
        raise InvalidParameterError(
            f"dir: {', '.join(repr(str(d / RESULTS_NAME)) for d in sources)} "
            f"{'hold' if len(sources) > 1 else 'holds'} no finished episode yet "
            f"({len(bad)} line(s) not usable)."
        )
    written = {}
    if merged:
        written = write_merged(target, used, records)
    shown = _per_budget(records)
    rows = summarise(shown)
    paired = paired_differences(shown)
    out_paths = {name: target / name for name in _FILES}
    _write_csv(rows, out_paths["summary.csv"])
    out_paths["summary.json"].write_text(json.dumps(rows, indent=1, default=str))
    _write_csv(paired, out_paths["paired.csv"])
    out_paths["paired.json"].write_text(json.dumps(paired, indent=1, default=str))
    _write_md(shown, rows, paired, out_paths["summary.md"])
    _write_failed(shown, out_paths["summary.md"])
    if bad:
        _write_bad_lines(bad, out_paths["summary.md"])
    error_rates_figure(shown, out_paths["error_rates.png"])
    safety_figure(shown, out_paths["safety.png"])
    paired_figure(paired, out_paths["paired.png"])
    return {**out_paths, **written}


def _source(directory: str | os.PathLike) -> Path:
    """A sweep directory holding a readable results.jsonl."""
    d = check_input_dir("dir", directory)
    path = d / RESULTS_NAME
    if not path.exists():
        raise InvalidParameterError(f"dir: no {RESULTS_NAME} in {str(d)!r}; run 'simroad ablate --out {d}' first.")
    check_input_file("dir", path)
    return d


def _per_budget(records: list[dict]) -> list[dict]:
    """The records as reported: with more than one step budget among them, each
    scenario named with its budget, so that only episodes of one length are pooled."""
    if len({r.get("step_budget") for r in records}) <= 1:
        return records
    return [{**r, "scenario": f"{r['scenario']} ({r.get('step_budget') or '?'} steps)"} for r in records]
