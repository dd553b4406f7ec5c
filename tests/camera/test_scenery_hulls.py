"""The round canopies' triangles, written out in the code, are the convex hulls of their points."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from simroad.camera._scenery_solids import CANOPY_TEMPLATES


def _faces(simplices: np.ndarray) -> set[tuple[int, ...]]:
    return {tuple(sorted(int(i) for i in tri)) for tri in simplices}


def test_round_canopies_are_the_hulls_of_their_points():
    rounds = CANOPY_TEMPLATES["round"]
    assert len(rounds) == 6
    for verts, faces in rounds:
        assert verts.shape == (7, 3) and faces.shape == (10, 3) and faces.dtype == np.int32
        assert _faces(faces) == _faces(ConvexHull(verts).simplices)
        # every vertex lies on the hull (7 points spread on a sphere): all are used
        assert set(np.unique(faces).tolist()) == set(range(7))
