"""Shared fixtures, and the order of the tests. Everything runs headless (simroad sets
SDL's dummy driver).

A test over ~10 s on 2 cores carries ``@pytest.mark.slow`` where it is defined (or its
module sets ``pytestmark = pytest.mark.slow``); ``make test-fast`` deselects them. With
``-n`` (pytest-xdist's ``--dist load``) the slow tests are collected first, so that the
short ones fill in around them on the other worker instead of one long test starting
last and running alone at the end.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np
import pytest


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)  # stable: slow first, else as collected


def _shared_dir(tmp_path_factory: pytest.TempPathFactory, name: str) -> Path:
    """A directory all xdist workers of this run share (their base temp dirs' parent),
    or this process's own base temp dir without xdist."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    path = root / name
    path.mkdir(exist_ok=True)
    return path


@pytest.fixture(scope="session")
def computed_once(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Any]:
    """``computed_once(name, fn, *args, **kwargs)``: ``fn(*args, **kwargs)`` computed by
    the first worker that asks (the others wait on a file lock), pickled, and unpickled
    afresh for every caller, so no test sees another's changes to it.

    For deterministic, expensive test inputs (rendered frames, fitted detectors) that
    several tests or modules use: with ``-n 2`` a session fixture alone still computes
    them once per worker. ``name`` and the arguments' ``repr`` are the key.
    """
    cache = _shared_dir(tmp_path_factory, "computed-once")

    def get(name: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        key = hashlib.sha256(repr((name, args, sorted(kwargs.items()))).encode()).hexdigest()[:20]
        path = cache / f"{name}-{key}.pkl"
        with open(cache / f"{name}-{key}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            if not path.exists():
                tmp = path.with_suffix(f".{os.getpid()}.tmp")
                tmp.write_bytes(pickle.dumps(fn(*args, **kwargs), protocol=pickle.HIGHEST_PROTOCOL))
                tmp.replace(path)
        return pickle.loads(path.read_bytes())

    return get


@pytest.fixture(scope="session")
def shared_frames(computed_once: Callable[..., Any]) -> Callable[..., Any]:
    """``collect_frames(**kwargs)`` rendered once per test run (see :func:`computed_once`):
    the same frames as a call of its own, as the record tests' frame hashes check."""
    from simroad.experiments.frames import collect_frames

    def get(**kwargs: Any) -> Any:
        return computed_once("frames", collect_frames, **kwargs)

    return get


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
