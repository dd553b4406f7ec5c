"""Morphological post-processing (paper §III-D, eq. 31).

The road is assumed to be one connected region: keep the connected component the ego
stands on and fill its holes. Road components are 8-connected; the background is
4-connected when looking for holes, the complementary topology (as in
``scipy.ndimage.binary_fill_holes``).
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

from simroad.core.validation import check_mask

__all__ = ["extend_upward", "fill_holes", "keep_ego_component", "postprocess"]

#: Bottom-centre window where the ego stands: last 1/8 of the rows, middle third of columns.
_EGO_ROWS = 8
_EGO_COLS = 3


def _mask_arg(mask: np.ndarray) -> np.ndarray:
    """The public functions' ``mask`` argument, checked and C-contiguous (for OpenCV)."""
    return np.ascontiguousarray(check_mask("mask", mask))


def _ego_component(mask: np.ndarray) -> np.ndarray:
    n, labels = cv2.connectedComponents(mask.view(np.uint8), connectivity=8)
    if n <= 1:
        return mask.copy()
    h, w = mask.shape
    c0 = w // _EGO_COLS
    window = labels[h - max(1, h // _EGO_ROWS) :, c0 : max(c0 + 1, w - c0)]
    votes = np.bincount(window.ravel(), minlength=n)
    votes[0] = 0
    if votes.max() == 0:  # no road under the ego: fall back to the largest region
        votes = np.bincount(labels.ravel(), minlength=n)
        votes[0] = 0
    return labels == int(np.argmax(votes))


def _ego_component_apart(mask: np.ndarray, marks: np.ndarray) -> np.ndarray:
    """The ego's component of ``mask`` found without the pixels of ``marks`` (lane
    markings, which would bridge the road to a pale verge), and the marked road pixels
    that touch it (8-connected components of ``mask & marks``) added back. (Adding every
    marking that touches the component, whatever the classifier called it, recovers
    painted lines but also kerb faces and pale verge edges: on held-out worlds FNR
    0.12 -> 0.08 for FPR 0.10 -> 0.18.)"""
    core = _ego_component(mask & ~marks)
    lines = mask & marks
    if not lines.any():
        return core
    n, labels = cv2.connectedComponents(lines.view(np.uint8), connectivity=8)
    near = cv2.dilate(core.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)
    touching = np.zeros(n, bool)
    touching[labels[near]] = True
    touching[0] = False
    return core | touching[labels]


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    # Background components (4-connected) that do not touch the border are holes. Framed
    # by a one-pixel ring of background, every component that touches the border joins
    # the ring: one 4-connected flood fill from a corner finds them all.
    h, w = mask.shape
    background = np.ones((h + 2, w + 2), np.uint8)
    np.logical_not(mask, out=background[1:-1, 1:-1].view(bool))
    cv2.floodFill(background, None, (0, 0), 2, flags=4)
    return background[1:-1, 1:-1] != 2


@njit(cache=True, nogil=True)
def _extend_upward(road: np.ndarray, seed: np.ndarray, out: np.ndarray) -> None:
    """``out``: the runs of ``road`` (a row's horizontal stretches) that hold a ``seed``
    pixel or touch (8-connected) a run already kept in the row below, from the bottom
    row up."""
    h, w = road.shape
    for r in range(h - 1, -1, -1):
        x = 0
        while x < w:
            if not road[r, x]:
                x += 1
                continue
            start, hit = x, False
            while x < w and road[r, x]:
                if not hit:
                    if seed[r, x]:
                        hit = True
                    elif r + 1 < h and (
                        out[r + 1, x] or (x > 0 and out[r + 1, x - 1]) or (x + 1 < w and out[r + 1, x + 1])
                    ):
                        hit = True
                x += 1
            if hit:
                out[r, start:x] = True


def extend_upward(road: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """The part of ``road`` that ``seed`` reaches going up the image: a row's run of road
    is kept when it holds a seed pixel or touches a kept run in the row below.

    On flat ground the road seen from the car only recedes upwards, so what a filter
    adds to the road it finds without the filter is the far road above it; a region
    that joins the road only through rows above it (a verge the classifier calls road,
    which a painted line kept apart near the car) is not reached.

    Parameters
    ----------
    road, seed : ndarray, bool, (H, W)

    Returns
    -------
    ndarray, bool, (H, W)
        A subset of ``road``.
    """
    road = np.ascontiguousarray(check_mask("road", road))
    seed = np.ascontiguousarray(check_mask("seed", seed, road.shape))
    out = np.zeros(road.shape, bool)
    _extend_upward(road, seed, out)
    return out


def keep_ego_component(mask: np.ndarray) -> np.ndarray:
    """Keep the connected road region the ego stands on.

    That is the 8-connected component covering most of the bottom-centre window (the
    last eighth of the rows, the middle third of the columns); if no road pixel lies
    there, the largest component.

    Parameters
    ----------
    mask : ndarray, bool, (H, W)
        The road pixels, e.g. as the classifier labelled them.

    Returns
    -------
    ndarray, bool, (H, W)
        The ego's component alone (a copy of ``mask`` when it holds no road).
    """
    return _ego_component(_mask_arg(mask))


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """Fill the holes of a mask (paper eq. 31).

    Eq. 31 grows ``X_k = (X_{k-1} (+) B) n A^c`` from a seed until it stops changing;
    the holes are the background pixels that such growth from the image border never
    reaches. We frame the background with a one-pixel ring and flood fill it
    (4-connected, ``cv2.floodFill``) from a corner: what the fill does not reach is the
    mask and its holes, the same set in one pass.

    Parameters
    ----------
    mask : ndarray, bool, (H, W)
        The region whose holes to fill.

    Returns
    -------
    ndarray, bool, (H, W)
        ``mask`` with its holes set.
    """
    return _fill_holes(_mask_arg(mask))


def postprocess(mask: np.ndarray) -> np.ndarray:
    """:func:`keep_ego_component` then :func:`fill_holes`; (H, W) bool."""
    return _fill_holes(_ego_component(_mask_arg(mask)))
