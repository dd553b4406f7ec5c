"""Morphological post-processing (paper §III-D, eq. 31).

The road is assumed to be one connected region: keep the connected component the ego
stands on and fill its holes. Road components are 8-connected; the background is
4-connected when looking for holes, the complementary topology (as in
``scipy.ndimage.binary_fill_holes``).
"""

from __future__ import annotations

import cv2
import numpy as np

from simroad._validation import check_mask

__all__ = ["fill_holes", "keep_ego_component", "postprocess"]

#: Bottom-centre window where the ego stands: last 1/8 of the rows, middle third of columns.
_EGO_ROWS = 8
_EGO_COLS = 3


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


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    # Background components (4-connected) that do not touch the border are holes. Framed
    # by a one-pixel ring of background, every component that touches the border joins
    # the ring: one 4-connected flood fill from a corner finds them all.
    h, w = mask.shape
    background = np.ones((h + 2, w + 2), np.uint8)
    np.logical_not(mask, out=background[1:-1, 1:-1].view(bool))
    cv2.floodFill(background, None, (0, 0), 2, flags=4)
    return background[1:-1, 1:-1] != 2


def keep_ego_component(mask: np.ndarray) -> np.ndarray:
    """Keep the connected road region the ego stands on.

    That is the 8-connected component covering most of the bottom-centre window (the
    last eighth of the rows, the middle third of the columns); if no road pixel lies
    there, the largest component.

    Parameters
    ----------
    mask : ndarray, bool, (H, W)

    Returns
    -------
    ndarray, bool, (H, W)
    """
    mask = np.ascontiguousarray(check_mask("mask", mask))
    return _ego_component(mask)


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

    Returns
    -------
    ndarray, bool, (H, W)
    """
    mask = np.ascontiguousarray(check_mask("mask", mask))
    return _fill_holes(mask)


def postprocess(mask: np.ndarray) -> np.ndarray:
    """:func:`keep_ego_component` then :func:`fill_holes`; (H, W) bool."""
    mask = np.ascontiguousarray(check_mask("mask", mask))
    return _fill_holes(_ego_component(mask))
