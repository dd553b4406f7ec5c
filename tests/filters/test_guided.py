"""He's guided filter (paper eq. 21) against a direct, loop-based implementation."""

from __future__ import annotations

import numpy as np
import pytest

from simroad import SimroadError
from simroad.filters import box_mean, guided_filter


def _window(i: int, j: int, r: int, h: int, w: int) -> tuple[slice, slice]:
    return slice(max(0, i - r), min(h, i + r + 1)), slice(max(0, j - r), min(w, j + r + 1))


def guided_loop(guide: np.ndarray, src: np.ndarray, r: int, eps: float) -> np.ndarray:
    """He, Sun & Tang (2013), Algorithm 1, written out window by window in float64."""
    guide, src = guide.astype(np.float64), src.astype(np.float64)
    h, w = guide.shape
    a, b = np.zeros((h, w)), np.zeros((h, w))
    for ky in range(h):
        for kx in range(w):
            win = _window(ky, kx, r, h, w)  # the window w_k centred on pixel k
            gi, pi = guide[win], src[win]
            mu, var, pbar = gi.mean(), gi.var(), pi.mean()
            a[ky, kx] = ((gi * pi).mean() - mu * pbar) / (var + eps)
            b[ky, kx] = pbar - a[ky, kx] * mu
    q = np.zeros((h, w))
    for i in range(h):
        for j in range(w):
            win = _window(i, j, r, h, w)  # the windows w_k that contain pixel i
            q[i, j] = a[win].mean() * guide[i, j] + b[win].mean()
    return q


@pytest.mark.parametrize("radius,eps", [(1, 1e-3), (2, 1e-2), (4, 1e-4), (20, 1e-3)])
def test_guided_filter_matches_loop_reference(radius, eps):
    rng = np.random.default_rng(radius)
    guide = rng.random((11, 14), dtype=np.float32)
    src = np.clip(guide + rng.normal(0, 0.1, guide.shape), 0, 1).astype(np.float32)
    got = guided_filter(guide, src, radius, eps)
    assert got.dtype == np.float32 and got.shape == src.shape
    np.testing.assert_allclose(got, guided_loop(guide, src, radius, eps), atol=2e-4)


def test_guided_filter_filters_each_channel_with_the_grey_guide():
    rng = np.random.default_rng(7)
    guide = rng.random((9, 10), dtype=np.float32)
    src = rng.random((9, 10, 3), dtype=np.float32)
    got = guided_filter(guide, src, 2, 1e-3)
    for c in range(3):
        np.testing.assert_allclose(got[..., c], guided_loop(guide, src[..., c], 2, 1e-3), atol=2e-4)


def test_guided_filter_self_guided_keeps_strong_edge_and_flattens_noise():
    img = np.zeros((20, 20), np.float32)
    img[:, 10:] = 1.0
    out = guided_filter(img, img, 3, 1e-3)
    np.testing.assert_allclose(out, img, atol=1e-2)  # sigma^2 >> eps at the edge: kept
    noise = (np.random.default_rng(0).random((20, 20)) * 0.02 + 0.5).astype(np.float32)
    assert guided_filter(noise, noise, 3, 1e-2).std() < 0.2 * noise.std()


def test_box_mean_is_the_clipped_window_mean():
    x = np.random.default_rng(3).random((6, 9), dtype=np.float32)
    expect = np.array([[x[_window(i, j, 2, 6, 9)].mean() for j in range(9)] for i in range(6)])
    np.testing.assert_allclose(box_mean(x, 2), expect, atol=1e-6)


def test_subsampled_guided_filter_is_close_on_smooth_images():
    yy, xx = np.mgrid[0:60, 0:80].astype(np.float32)
    guide = (0.5 + 0.4 * np.sin(xx / 9) * np.cos(yy / 11)).astype(np.float32)
    src = np.clip(guide * 0.8 + 0.1, 0, 1).astype(np.float32)
    exact = guided_filter(guide, src, 4, 1e-3)
    fast = guided_filter(guide, src, 4, 1e-3, subsample=2)
    assert np.abs(exact - fast).mean() < 5e-3


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"guide": np.zeros((5, 5, 3), np.float32)}, "guide: expected an array of shape"),
        ({"guide": np.zeros((5, 5), np.float64)}, "guide: expected dtype float32"),
        ({"src": np.zeros((4, 5), np.float32)}, "src: expected the height and width"),
        ({"src": np.full((5, 5), np.nan, np.float32)}, "src: expected finite values"),
        ({"src": np.full((5, 5), 2.0, np.float32)}, r"src: float images must lie in \[0, 1\]"),
        ({"radius": 0}, "radius: expected an integer"),
        ({"eps": 0.0}, "eps: expected a value in"),
        ({"subsample": 0}, "subsample: expected an integer"),
    ],
)
def test_guided_filter_rejects_bad_input(kwargs, match):
    args = {"guide": np.zeros((5, 5), np.float32), "src": np.zeros((5, 5), np.float32), "radius": 1, "eps": 1e-3}
    args.update(kwargs)
    with pytest.raises(SimroadError, match=match):
        guided_filter(args["guide"], args["src"], args["radius"], args["eps"], subsample=args.get("subsample", 1))
