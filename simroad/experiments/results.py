"""Read and append a sweep's ``results.jsonl``: what a valid row is, and nothing lost.

A **valid row** is one JSON object per line holding every key of
:data:`~simroad.experiments.episode.RECORD_KEYS` with the types of :data:`ROW_TYPES`
(``error``, written by the sweep runner, is optional: null or a string). Everything
else — a line that is not JSON, a torn line, a wrong type (``severity="high"``,
``scenario=5``), a missing key, a second row for a cell already recorded (the grid's
:func:`~simroad.experiments.grid.cell_key`) — is a **bad line**, named by its line
number and why. :func:`read_results` never changes the file; only the sweep runner
(:meth:`ResultStore.open`) repairs it, and only what a crash or an older version can
leave: a torn last line and duplicate rows are *moved* to ``results.rejected.jsonl``
(one JSON object per moved line: ``line``, ``reason``, ``text``, ``moved_at``), never
deleted. Any other bad line stops the runner with a message naming it.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from simroad.errors import InvalidParameterError
from simroad.experiments.episode import RECORD_KEYS
from simroad.experiments.grid import AblationGrid, cell_key
from simroad.experiments.outlock import _stderr

__all__ = [
    "REJECTED_NAME",
    "RESULTS_NAME",
    "ROW_TYPES",
    "SOURCES_NAME",
    "BadLine",
    "ResultStore",
    "check_merge_target",
    "check_row",
    "grid_steps",
    "merge_results",
    "read_results",
    "write_merged",
]

RESULTS_NAME = "results.jsonl"
REJECTED_NAME = "results.rejected.jsonl"
#: A merged report's record of its sources (:func:`write_merged`).
SOURCES_NAME = "sources.json"

#: Expected type of each key of a row, by kind: ``text`` a string; ``count`` an int
#: >= 0 (not a bool); ``budget`` an int >= 1; ``severity`` a number in [0, 1]; ``number`` an int or float
#: (NaN for a failed episode); ``flag`` a bool or a number (NaN for a failed episode);
#: ``number|null`` a number or null; ``text|null`` a string or null (optional key);
#: ``label`` a string, empty where it does not apply (the oracle has no detector);
#: ``table`` a JSON object (the camera profile's fields).
ROW_TYPES: dict[str, str] = {
    **dict.fromkeys(RECORD_KEYS, "number"),
    **dict.fromkeys(("scenario", "noise", "filters", "driver"), "text"),
    **dict.fromkeys(("detector", "detector_version", "detector_spec"), "label"),
    **dict.fromkeys(("seed", "steps"), "count"),
    "step_budget": "budget",
    "severity": "severity",
    "collided": "flag",
    "min_ttc_s": "number|null",
    "min_stopping_margin_m": "number|null",
    "friction": "flag",
    "camera_profile": "table",
    "detector_options": "table",
    "env_options": "table",
    "error": "text|null",
}
#: Keys a row may lack (rows written before records held them).
_OPTIONAL = ("error", "camera_profile", "start_speed_m_s", "detector_options", "env_options", "step_budget")


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


_CHECKS: dict[str, Callable[[Any], bool]] = {
    "text": lambda v: isinstance(v, str) and v != "",
    "count": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
    "budget": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1,
    "severity": lambda v: _is_number(v) and 0.0 <= v <= 1.0,
    "number": _is_number,
    "flag": lambda v: isinstance(v, bool) or _is_number(v),
    "number|null": lambda v: v is None or _is_number(v),
    "text|null": lambda v: v is None or isinstance(v, str),
    "label": lambda v: isinstance(v, str),
    "table": lambda v: isinstance(v, Mapping) and all(isinstance(k, str) for k in v),
}
_EXPECTED = {
    "text": "a non-empty string",
    "count": "an integer >= 0",
    "budget": "an integer >= 1",
    "severity": "a number in [0, 1]",
    "number": "a number",
    "flag": "true, false or a number",
    "number|null": "a number or null",
    "text|null": "a string or null",
    "label": "a string",
    "table": "a JSON object of named values",
}


def check_row(row: Any) -> str | None:
    """Why ``row`` (one parsed JSON line) is not a valid results row, or None if it is.

    Parameters
    ----------
    row : object
        What ``json.loads`` gave for one line.

    Returns
    -------
    str or None
        A short reason naming the first wrong key (``severity is 'high' (str),
        expected a number in [0, 1]``) or every missing key; None for a valid row.
    """
    if not isinstance(row, Mapping):
        return f"not a JSON object but {type(row).__name__}"
    missing = [k for k in ROW_TYPES if k not in row and k not in _OPTIONAL]
    if missing:
        shown = ", ".join(missing[:6]) + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
        return f"missing key{'s' if len(missing) > 1 else ''} {shown}"
    for key, kind in ROW_TYPES.items():
        if key in row and not _CHECKS[kind](row[key]):
            value = row[key]
            return f"{key} is {value!r} ({type(value).__name__}), expected {_EXPECTED[kind]}"
    return None


@dataclass(frozen=True)
class BadLine:
    """One line of ``results.jsonl`` that is not used: its 1-based number, why, its text."""

    number: int
    reason: str
    text: str
    torn: bool = False
    duplicate: bool = False
    source: str = ""  # the file, when lines of several files are read together

    def __str__(self) -> str:
        return f"{self.source + ' ' if self.source else ''}line {self.number}: {self.reason}"


def _parse_line(number: int, raw: bytes, *, torn: bool) -> dict | BadLine:
    text = raw.decode("utf-8", errors="surrogateescape")
    why = "torn (the last line ends without a newline: a write cut short)" if torn else None
    try:
        row = json.loads(raw)
    except (ValueError, UnicodeDecodeError) as exc:
        reason = why or ("an empty line" if not raw.strip() else f"not JSON ({exc})")
        return BadLine(number, reason, text, torn=torn)
    problem = check_row(row)
    if problem is not None:
        return BadLine(number, f"{why}; {problem}" if why else problem, text, torn=torn)
    return row


def read_results(path: str | os.PathLike, *, default_budget: int | None = None) -> tuple[list[dict], list[BadLine]]:
    """Read a results file without changing it: the valid rows, one per cell, and the bad lines.

    Parameters
    ----------
    path : path
        A ``results.jsonl``.
    default_budget : int, optional
        The step budget of rows written before rows held ``step_budget`` (the ``steps``
        of the sweep's ``grid.json``, :func:`grid_steps`); without it such a row's cell
        takes the steps it drove.

    Returns
    -------
    rows : list of dict
        The valid rows in file order; of several rows for one cell, the first.
    bad : list of BadLine
        Every other line, with its number and why (``torn`` set for a torn last line,
        ``duplicate`` for a later row of a cell already recorded).
    """
    rows: dict[str, tuple[dict, str, int]] = {}
    bad: list[BadLine] = []
    _collect(Path(path), default_budget, rows, bad, source="")
    return [row for row, _, _ in rows.values()], bad


def _collect(
    path: Path, default_budget: int | None, rows: dict[str, tuple[dict, str, int]], bad: list[BadLine], source: str
) -> None:
    """Add the valid rows of ``path`` to ``rows`` (cell -> row, file, line) unless their
    cell is there already, and every other line to ``bad``."""
    data = path.read_bytes()
    lines = data.split(b"\n")
    complete = lines[-1] == b""
    if complete:
        lines.pop()
    for i, raw in enumerate(lines, start=1):
        parsed = _parse_line(i, raw, torn=i == len(lines) and not complete)
        if isinstance(parsed, BadLine):
            bad.append(replace(parsed, source=source))
            continue
        if default_budget is not None:
            parsed.setdefault("step_budget", default_budget)
        key = cell_key(parsed, default_budget=default_budget)
        if key in rows:
            _, where, line = rows[key]
            of = f"line {line}" if where == source else f"{where} line {line}"
            text = raw.decode("utf-8", errors="surrogateescape")
            bad.append(BadLine(i, f"duplicate of {of} (cell {key})", text, duplicate=True, source=source))
            continue
        rows[key] = (parsed, source, i)


def merge_results(
    directories: Sequence[str | os.PathLike],
) -> tuple[list[dict], list[BadLine], dict[str, int]]:
    """The valid rows of several sweeps' ``results.jsonl``, one per cell, and every line not used.

    Each file is read as :func:`read_results` reads it (rows written before rows held
    ``step_budget`` take the ``steps`` of the ``grid.json`` beside them). A cell in more
    than one file keeps its first row; each later one is a bad line naming the first.

    Returns
    -------
    rows : list of dict
        The rows used, file by file in the order given.
    bad : list of BadLine
        Every other line, with its file in ``source``.
    used : dict of str to int
        Each file -> how many of its rows were used.
    """
    rows: dict[str, tuple[dict, str, int]] = {}
    bad: list[BadLine] = []
    names = [str(Path(d) / RESULTS_NAME) for d in directories]
    for d, name in zip(directories, names, strict=True):
        _collect(Path(name), grid_steps(d), rows, bad, source=name)
    used = {name: sum(where == name for _, where, _ in rows.values()) for name in names}
    return [row for row, _, _ in rows.values()], bad, used


class ResultStore:
    """Append-only JSON-lines results; the sweep runner's side (repairs, appends).

    Parameters
    ----------
    directory : path
        Holds ``results.jsonl``, ``grid.json`` and ``results.rejected.jsonl``.
    log : callable, optional
        Receives one message per repair (default: print to stderr).
    """

    def __init__(self, directory: str | os.PathLike, *, log: Callable[[str], None] | None = None) -> None:
        if not isinstance(directory, (str, os.PathLike)) or not str(directory):
            raise InvalidParameterError(
                f"directory: expected a folder path (str or os.PathLike), got {type(directory).__name__} {directory!r}."
            )
        self.dir = Path(directory)
        self.path = self.dir / RESULTS_NAME
        self.grid_path = self.dir / "grid.json"
        self.rejected_path = self.dir / REJECTED_NAME
        self.log = log or _stderr
        self.default_budget: int | None = None

    def open(self, grid: AblationGrid, *, fresh: bool = False) -> dict[str, dict]:
        """Prepare the directory for ``grid`` and return the records already done.

        The caller holds the directory's lock (:mod:`simroad.experiments.outlock`).
        """
        meta = {"fingerprint": grid.fingerprint(), "grid": asdict(grid)}
        self.default_budget = grid.steps  # a grown grid runs the same steps as the old one
        if self.grid_path.exists() and not fresh:
            try:
                old = json.loads(self.grid_path.read_text())
                old_print, old_grid = old.get("fingerprint"), old.get("grid")
            except (ValueError, UnicodeDecodeError, AttributeError):
                raise InvalidParameterError(
                    f"out: {str(self.grid_path)!r} is damaged (not the JSON object simroad writes). "
                    "Choose another --out, or pass --fresh to delete the results there and start anew."
                ) from None
            if old_print != meta["fingerprint"] and not (isinstance(old_grid, Mapping) and grid.grows(old_grid)):
                raise InvalidParameterError(
                    f"out: {str(self.dir)!r} holds results of a different grid ({old_grid}). A grid that holds "
                    "every cell of it, run the same way (steps, traffic, friction, camera, options), grows it "
                    "instead. Choose another --out, or pass --fresh to delete them and start anew."
                )
        if fresh and self.path.exists():
            self.path.unlink()
        _atomic_write(self.grid_path, json.dumps(meta, indent=1))
        return self.repair()

    def repair(self) -> dict[str, dict]:
        """Move a torn last line and duplicate rows to ``results.rejected.jsonl``; return
        the valid records by cell. Any other bad line raises :class:`SimroadError`."""
        if not self.path.exists():
            return {}
        rows, bad = read_results(self.path, default_budget=self.default_budget)
        others = [b for b in bad if not (b.torn or b.duplicate)]
        if others:
            listed = "; ".join(str(b) for b in others[:10]) + (
                f"; and {len(others) - 10} more" if len(others) > 10 else ""
            )
            raise InvalidParameterError(
                f"out: {str(self.path)!r} has lines that are not valid results rows ({listed}). "
                f"Move them out of the file (e.g. into {REJECTED_NAME}) and rerun to run their cells again, "
                "or pass --fresh to start anew; 'simroad report' lists them too."
            )
        if bad:
            self._move_aside(bad)
        elif not self.path.read_bytes().endswith(b"\n") and self.path.stat().st_size:
            with open(self.path, "ab") as fh:  # a complete row whose newline was cut: finish it
                fh.write(b"\n")
                fh.flush()
                os.fsync(fh.fileno())
        return {cell_key(r, default_budget=self.default_budget): r for r in rows}

    def _move_aside(self, bad: list[BadLine]) -> None:
        stamp = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        moved = "".join(
            json.dumps({"line": b.number, "reason": b.reason, "text": b.text, "moved_at": stamp}) + "\n" for b in bad
        )
        with open(self.rejected_path, "a") as fh:
            fh.write(moved)
            fh.flush()
            os.fsync(fh.fileno())
        data = self.path.read_bytes()
        if len(bad) == 1 and bad[0].torn:  # only the torn tail: cut it off in place
            os.truncate(self.path, data.rfind(b"\n") + 1)
        else:  # keep every other line byte for byte
            drop = {b.number for b in bad}
            lines = data.split(b"\n")
            lines = lines[:-1] if lines[-1] == b"" else lines
            keep = [line for i, line in enumerate(lines, start=1) if i not in drop]
            _atomic_write(self.path, b"".join(line + b"\n" for line in keep))
        for b in bad:
            self.log(f"{self.path}: moved {b} to {self.rejected_path.name}")

    def append(self, record: dict) -> None:
        """Append one record durably with a single write."""
        line = (json.dumps(record) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)

    def records(self) -> list[dict]:
        """The valid records, one per cell, read without changing the file (bad lines skipped)."""
        return read_results(self.path, default_budget=self.default_budget)[0] if self.path.exists() else []


def check_merge_target(target: Path, sources: list[Path]) -> None:
    """Refuse to write merged rows over a source or over a sweep's own results."""
    if any(target.resolve() == d.resolve() for d in sources):
        raise InvalidParameterError(
            f"out: {str(target)!r} is one of the sweeps reported; a report over several sweeps goes to a new folder."
        )
    if (target / RESULTS_NAME).exists() and not (target / SOURCES_NAME).exists():
        raise InvalidParameterError(
            f"out: {str(target)!r} holds a sweep's own {RESULTS_NAME}, which a merged report would replace. "
            "Choose a new folder."
        )


def write_merged(target: Path, used: dict[str, int], records: list[dict]) -> dict[str, Path]:
    """The rows used and where they came from, so that ``simroad report OUT`` rebuilds the report."""
    (target / RESULTS_NAME).write_text("".join(json.dumps(r) + "\n" for r in records))
    listed = [{"results": name, "rows_used": n} for name, n in used.items()]
    (target / SOURCES_NAME).write_text(json.dumps({"sources": listed, "rows": len(records)}, indent=1) + "\n")
    return {RESULTS_NAME: target / RESULTS_NAME, SOURCES_NAME: target / SOURCES_NAME}


def grid_steps(directory: str | os.PathLike) -> int | None:
    """The ``steps`` of the grid in ``directory``'s ``grid.json``; None without a readable one."""
    try:
        steps = json.loads((Path(directory) / "grid.json").read_text())["grid"]["steps"]
    except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError):
        return None
    return steps if isinstance(steps, int) and not isinstance(steps, bool) and steps > 0 else None


def _atomic_write(path: Path, data: str | bytes) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "wb") as fh:
        fh.write(data.encode() if isinstance(data, str) else data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
