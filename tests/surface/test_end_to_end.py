"""A handful of bad inputs through a real ``python -m simroad`` process: exit status 2,
the flag or key named on stderr, and no traceback -- end to end (the in-process cases
are in test_cli_surface.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import simroad

pytestmark = pytest.mark.slow  # each case starts a fresh interpreter

_ENV = {**os.environ, "PYTHONPATH": str(Path(simroad.__file__).resolve().parents[1])}


def _cases(tmp: Path) -> list[tuple[list[str], str]]:
    blocker = tmp / "file.txt"
    blocker.write_text("x")
    toml = tmp / "grid.toml"
    toml.write_text('severities = [0.5, "x"]\nout = "%s"\n' % (tmp / "s"))
    return [
        (["frames", "--seed", "-1", "--out", str(tmp / "f")], "--seed"),
        (["ablate", "--config", str(toml)], "severities"),
        (["figure", "camera", "--out", str(blocker / "f.png")], "--out"),
        (["evaluate-detector", "--images", str(tmp), "--masks", str(tmp), "--frames", "3"], "--frames"),
    ]


@pytest.mark.parametrize("k", range(4))
def test_bad_input_exits_2_without_traceback(k, tmp_path):
    argv, name = _cases(tmp_path)[k]
    res = subprocess.run(
        [sys.executable, "-m", "simroad", *argv], capture_output=True, text=True, env=_ENV, timeout=120
    )
    assert res.returncode == 2, res.stderr
    assert name in res.stderr and "Traceback" not in res.stderr
