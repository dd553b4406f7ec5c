"""The per-thread work arrays (simroad.filters._workspace) and the relighting that uses them."""

from __future__ import annotations

import threading

import numpy as np

from simroad.core.radiometry import linear_to_srgb
from simroad.filters import relight_shadows
from simroad.filters._workspace import scratch


def _shadowed(seed: int) -> np.ndarray:
    """A 120x200 frame: a clear sky over asphalt, a soft-edged cast shadow across the ground (uint8)."""
    rng = np.random.default_rng(seed)
    lin = np.empty((120, 200, 3))
    lin[:40] = (0.35, 0.55, 0.9)
    lin[40:] = np.array([0.12, 0.114, 0.108]) * (1.0 + rng.normal(0.0, 0.03, (80, 200, 1)))
    cover = np.clip((np.arange(200) - 60 - 10 * seed) / 8.0, 0.0, 1.0) * np.clip((150 - np.arange(200)) / 8.0, 0.0, 1.0)
    lin[70:] *= 1.0 - cover[None, :, None] * (1.0 - np.array([0.25, 0.31, 0.47]))
    return linear_to_srgb((2.0 * lin / (1.0 + lin)).astype(np.float32))


def test_scratch_is_the_same_array_per_name_shape_and_dtype_in_a_thread():
    a = scratch("test a", (4, 5), np.float32)
    assert a.shape == (4, 5) and a.dtype == np.float32 and a.flags.c_contiguous
    assert scratch("test a", (4, 5), np.float32) is a
    assert scratch("test a", (4, 6), np.float32) is not a
    assert scratch("test a", (4, 5), np.float64) is not a
    assert scratch("test b", (4, 5), np.float32) is not a


def test_scratch_is_each_threads_own():
    mine = scratch("test threads", (8,), np.int64)
    theirs = []
    worker = threading.Thread(target=lambda: theirs.append(scratch("test threads", (8,), np.int64)))
    worker.start()
    worker.join()
    assert theirs[0] is not mine and not np.shares_memory(theirs[0], mine)


def test_relighting_in_threads_is_the_relighting_alone():
    """Threads relighting at once (their work arrays their own) give what one thread gives."""
    frames = [_shadowed(seed) for seed in range(4)]
    alone = [relight_shadows(f) for f in frames]
    assert all(r.mask.any() for r in alone)
    got: dict[int, list] = {}

    def run(k: int) -> None:
        got[k] = [relight_shadows(f) for f in frames[k:] + frames[:k] for _ in range(3)]

    workers = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    for t in workers:
        t.start()
    for t in workers:
        t.join()
    for k, results in got.items():
        for i, res in enumerate(results):
            expect = alone[(k + i // 3) % 4]
            np.testing.assert_array_equal(res.image, expect.image)
            np.testing.assert_array_equal(res.mask, expect.mask)
