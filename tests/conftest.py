"""Shared fixtures, and the order of the tests. Everything runs headless (simroad sets
SDL's dummy driver).

A test over ~10 s on 2 cores carries ``@pytest.mark.slow`` where it is defined (or its
module sets ``pytestmark = pytest.mark.slow``); ``make test-fast`` deselects them. With
``-n`` (pytest-xdist's ``--dist load``) the slow tests are collected first, so that the
short ones fill in around them on the other worker instead of one long test starting
last and running alone at the end.
"""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np
import pytest


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)  # stable: slow first, else as collected


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
