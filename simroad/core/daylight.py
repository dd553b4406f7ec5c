"""The colour of daylight: correlated colour temperature (CCT) to linear sRGB.

Daylight's chromaticity lies on the CIE daylight locus (CIE 15:2004, eqs. 3.3-3.4):
for a CCT ``T`` in kelvin,

``x_D = -4.6070e9 / T^3 + 2.9678e6 / T^2 + 0.09911e3 / T + 0.244063``  (4000-7000 K)
``x_D = -2.0064e9 / T^3 + 1.9018e6 / T^2 + 0.24748e3 / T + 0.237040``  (7000-25000 K)
``y_D = -3.000 x_D^2 + 2.870 x_D - 0.275``

The colour is turned into linear sRGB (IEC 61966-2-1's XYZ-to-RGB matrix) with unit
luminance and then divided by its green channel, so D65 (6504 K) is about
``(1, 1, 1)``, warmer light has red above one and blue below, colder the reverse.
A camera's white balance is the ratio of two such colours (the light's and the one
the camera balances for); mixing light colours is linear in mired (``1e6 / T``),
the scale colour temperature differences are judged on.
"""

from __future__ import annotations

import numpy as np

from simroad.core.validation import check_in_range

__all__ = ["CCT_RANGE_K", "daylight_rgb", "mired_mix"]

#: CCTs the daylight locus covers (kelvin).
CCT_RANGE_K = (4000.0, 25000.0)

_XYZ_TO_RGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]], dtype=np.float64
)


def daylight_rgb(cct_k: float) -> np.ndarray:
    """Linear sRGB of daylight of CCT ``cct_k`` (K), green = 1: float64 (3,)."""
    t = check_in_range("cct_k", cct_k, *CCT_RANGE_K, unit="K")
    if t <= 7000.0:
        x = -4.6070e9 / t**3 + 2.9678e6 / t**2 + 0.09911e3 / t + 0.244063
    else:
        x = -2.0064e9 / t**3 + 1.9018e6 / t**2 + 0.24748e3 / t + 0.237040
    y = -3.000 * x * x + 2.870 * x - 0.275
    xyz = np.array([x / y, 1.0, (1.0 - x - y) / y])
    rgb = _XYZ_TO_RGB @ xyz
    return rgb / rgb[1]


def mired_mix(a_k: float, b_k: float, weight_b: float) -> float:
    """The CCT (K) ``weight_b`` of the way from ``a_k`` to ``b_k`` in mired."""
    w = check_in_range("weight_b", weight_b, 0.0, 1.0)
    return 1e6 / ((1.0 - w) * 1e6 / a_k + w * 1e6 / b_k)
