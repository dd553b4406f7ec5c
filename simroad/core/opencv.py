"""OpenCV the same on every CPU: its Intel IPP path switched off.

OpenCV hands many image functions (Gaussian and box filters, warps, colour
conversions, means) to Intel's IPP, which picks its code by the CPU's vector width
(SSE4.2, AVX2, AVX-512) and rounds differently in each: the same seed gave other
frames on an AVX-512 machine than on an AVX2 one. OpenCV's own kernels, which it
also dispatches by CPU, give the same bits at every width for everything simroad
calls (``tests/experiments/test_reproducible.py`` reruns with them restricted), and
on CPUs without IPP (ARM). Without IPP simroad is no slower (``make bench``).

OpenCV reads ``OPENCV_IPP`` once, when IPP is first asked for: importing simroad sets
it to ``disabled`` for that moment (OpenCV's warning about it silenced, the variable
removed again, so child processes inherit nothing), which turns IPP off in every
thread. Where OpenCV had already read it (IPP used before simroad was imported), the
switch is only per thread: importing simroad turns IPP off in the importing thread,
and :class:`simroad.envs.RoadCamEnv` again on the thread of each ``reset``. With
``OPENCV_IPP`` set in the environment (``avx2``, ``sse42``, ...) simroad leaves IPP as
OpenCV configured it; frames may then differ between machines.
"""

from __future__ import annotations

import os

import cv2

__all__ = ["IPP_ENV", "opencv_without_ipp"]

#: The environment variable by which a user configures OpenCV's IPP path themselves.
IPP_ENV = "OPENCV_IPP"
_tried = False  # the variable has been offered to OpenCV once


def opencv_without_ipp() -> None:
    """Switch OpenCV's IPP path off in every thread if OpenCV has not set it up yet, and
    in the calling thread in any case, unless the user configured it (:data:`IPP_ENV`)."""
    global _tried
    if IPP_ENV in os.environ:
        return
    if not _tried:
        _tried = True
        logging = getattr(getattr(cv2, "utils", None), "logging", None)
        level = logging.getLogLevel() if logging is not None else None
        os.environ[IPP_ENV] = "disabled"
        try:
            if logging is not None:  # OpenCV warns that the variable turned IPP off
                logging.setLogLevel(logging.LOG_LEVEL_ERROR)
            cv2.ipp.useIPP()  # the first question sets IPP up, reading the variable
        finally:
            del os.environ[IPP_ENV]
            if logging is not None:
                logging.setLogLevel(level)
    cv2.ipp.setUseIPP(False)
