"""Material codes: what every texel of the ground and every pixel of a frame is.

The camera's ``material`` map names what each pixel sees; the road mask is
:data:`IS_ROAD` on visible ground (asphalt and its markings). docs/materials.md
describes each material and its measured albedo.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ASPHALT",
    "BUILDING",
    "CITYSCAPES_LABELS",
    "CITYSCAPES_LABEL_ID",
    "GROUND_MATERIALS",
    "GUARDRAIL",
    "IS_GROUND",
    "IS_ROAD",
    "KERB",
    "MARKING",
    "MATERIAL_NAMES",
    "OVERPASS",
    "POLE",
    "ROADSIDE",
    "ROAD_MATERIALS",
    "SHOULDER",
    "SIDEWALK",
    "SIGN",
    "SKY",
    "VEGETATION",
    "VEHICLE",
    "WALL",
]

ROADSIDE, SHOULDER, ASPHALT, MARKING, VEHICLE, SKY = 0, 1, 2, 3, 4, 5
SIDEWALK, KERB = 6, 7  # ground beside a town street (not road)
VEGETATION, POLE, SIGN, BUILDING, WALL, GUARDRAIL, OVERPASS = 8, 9, 10, 11, 12, 13, 14

#: Name of every material code (docs/materials.md describes each).
MATERIAL_NAMES: dict[int, str] = {
    ROADSIDE: "roadside",
    SHOULDER: "shoulder",
    ASPHALT: "asphalt",
    MARKING: "marking",
    VEHICLE: "vehicle",
    SKY: "sky",
    SIDEWALK: "sidewalk",
    KERB: "kerb",
    VEGETATION: "vegetation",
    POLE: "pole",
    SIGN: "sign",
    BUILDING: "building",
    WALL: "wall",
    GUARDRAIL: "guardrail",
    OVERPASS: "overpass",
}
#: Codes a ground texel can carry.
GROUND_MATERIALS = frozenset({ROADSIDE, SHOULDER, ASPHALT, MARKING, SIDEWALK, KERB})
#: The drivable surface: asphalt and the markings painted on it.
ROAD_MATERIALS = frozenset({ASPHALT, MARKING})


def _lookup(codes: frozenset[int]) -> np.ndarray:
    out = np.zeros(256, dtype=bool)
    out[list(codes)] = True
    out.flags.writeable = False
    return out


#: ``IS_GROUND[material]`` / ``IS_ROAD[material]``: vectorised membership tests.
IS_GROUND = _lookup(GROUND_MATERIALS)
IS_ROAD = _lookup(ROAD_MATERIALS)


#: Cityscapes ``labelId`` of every material (Cordts et al. 2016, ``cityscapesscripts``
#: ``labels.py``): road 7 (asphalt and markings), sidewalk 8 (kerbs too, as Cityscapes
#: labels them), ground 6 (the shoulder), terrain 22 (the roadside), car 26 (every
#: vehicle), sky 23, vegetation 21, pole 17, traffic sign 20, building 11, wall 12,
#: guard rail 14, bridge 15 (an overpass).
CITYSCAPES_LABEL_ID: dict[int, int] = {
    ROADSIDE: 22, SHOULDER: 6, ASPHALT: 7, MARKING: 7, VEHICLE: 26, SKY: 23, SIDEWALK: 8, KERB: 8,
    VEGETATION: 21, POLE: 17, SIGN: 20, BUILDING: 11, WALL: 12, GUARDRAIL: 14, OVERPASS: 15,
}  # fmt: skip
#: ``CITYSCAPES_LABELS[material]``: the label image of a material map (0, unlabeled,
#: for a code that is not a material).
CITYSCAPES_LABELS = np.zeros(256, dtype=np.uint8)
CITYSCAPES_LABELS[list(CITYSCAPES_LABEL_ID)] = list(CITYSCAPES_LABEL_ID.values())
CITYSCAPES_LABELS.flags.writeable = False
