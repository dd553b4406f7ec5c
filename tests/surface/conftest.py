"""Fixtures of the surface-walking suite: files to point flags at, and a guard that
fails a case if any episode, frame, sweep or training starts before the input is refused."""

from __future__ import annotations

import pytest


class WorkStarted(Exception):
    """Raised by the guard: real work began although the input should have been refused."""


def _refuse_work(*_args, **_kwargs):
    raise WorkStarted("work started before the bad input was refused")


@pytest.fixture
def no_work(monkeypatch):
    """Make every entry to real work (an environment reset, a sweep, the weather
    gallery's scene, detector training) raise :class:`WorkStarted`."""
    from simroad.cli import commands
    from simroad.envs import RoadCamEnv

    monkeypatch.setattr(RoadCamEnv, "reset", _refuse_work)
    monkeypatch.setattr(commands, "run_ablation", _refuse_work)
    monkeypatch.setattr(commands, "build_report", _refuse_work)
    monkeypatch.setattr("simroad.experiments.gallery.sample_scene", _refuse_work)
    monkeypatch.setattr("simroad.detector.train_default", _refuse_work)


@pytest.fixture
def paths(tmp_path) -> dict[str, str]:
    """``file`` (a regular file), ``dir`` (an empty directory), ``missing`` (no such
    path), ``ok`` (a fresh directory to write in) and malformed inputs."""
    f = tmp_path / "file.txt"
    f.write_text("not what you expected\n")
    d = tmp_path / "adir"
    d.mkdir()
    ok = tmp_path / "ok"
    ok.mkdir()
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"PK\x03\x04 this is not a zip file at all")
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    return {
        "file": str(f),
        "dir": str(d),
        "missing": str(tmp_path / "no" / "such" / "path"),
        "ok": str(ok),
        "garbage": str(garbage),
        "empty": str(empty),
        "tmp": str(tmp_path),
    }


@pytest.fixture
def fill(paths):
    """``fill(text)``: replace ``{file}``, ``{dir}``, ``{missing}``, ``{ok}`` ... in ``text``."""

    def fill_(text: str) -> str:
        for key, value in paths.items():
            text = text.replace("{" + key + "}", value)
        return text

    return fill_


@pytest.fixture
def write(tmp_path):
    """``write(name, content)``: a file in the test's folder; returns its path."""

    def write_(name: str, content: str | bytes) -> str:
        p = tmp_path / name
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)
        return str(p)

    return write_
