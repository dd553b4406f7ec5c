"""OpenCV the same on every CPU: its Intel IPP path switched off.

OpenCV hands many image functions (Gaussian and box filters, warps, colour
conversions, means) to Intel's IPP, which picks its code by the CPU's vector width
(SSE4.2, AVX2, AVX-512) and rounds differently in each: the same seed gave other
frames on an AVX-512 machine than on an AVX2 one. OpenCV's own kernels, which it
also dispatches by CPU, give the same bits at every width for everything simroad
calls (``tests/experiments/test_reproducible.py`` reruns with them restricted), and
on CPUs without IPP (ARM). Without IPP simroad is no slower (``make bench``).

OpenCV keeps the switch per thread: importing simroad switches IPP off in the
importing thread, and :class:`simroad.envs.RoadCamEnv` switches it off again on the
thread of each ``reset`` (a vector env's or a user's worker thread). With
``OPENCV_IPP`` set in the environment (``avx2``, ``sse42``, ...) simroad leaves IPP as
OpenCV configured it; frames may then differ between machines. (simroad does not set
``OPENCV_IPP=disabled`` itself: OpenCV logs a warning for it in every process.)
"""

from __future__ import annotations

import os

import cv2

__all__ = ["IPP_ENV", "opencv_without_ipp"]

#: The environment variable by which a user configures OpenCV's IPP path themselves.
IPP_ENV = "OPENCV_IPP"


def opencv_without_ipp() -> None:
    """Switch OpenCV's IPP path off in the calling thread, unless the user configured
    it (:data:`IPP_ENV`)."""
    if IPP_ENV not in os.environ:
        cv2.ipp.setUseIPP(False)
