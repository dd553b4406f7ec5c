"""simroad switches OpenCV's IPP path off (its rounding follows the CPU's vector
width): in every thread when OpenCV has not set IPP up yet, else in the thread that
imports simroad and on the thread of every ``RoadCamEnv.reset``; an ``OPENCV_IPP`` the
user set is kept, simroad leaves none behind, and nothing is logged. Each case in a
fresh interpreter."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest


def _run(code: str, **env: str) -> list[str]:
    base = {k: v for k, v in os.environ.items() if k not in ("OPENCV_IPP", "OPENCV_LOG_LEVEL")}
    run = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env={**base, **env}, timeout=300
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert "IPP" not in run.stderr  # OpenCV's warning for OPENCV_IPP=disabled, silenced
    return run.stdout.split()


def _has_ipp() -> bool:
    return "True" in _run("import cv2; print(cv2.ipp.useIPP())")


pytestmark = pytest.mark.skipif(not _has_ipp(), reason="this OpenCV build has no IPP")


def test_simroad_imported_first_leaves_no_ipp_in_any_thread():
    code = """
        import os, threading
        import cv2
        import simroad
        seen = [cv2.ipp.useIPP()]
        def work():
            cv2.ipp.setUseIPP(True)  # a thread cannot turn it back on
            seen.append(cv2.ipp.useIPP())
        t = threading.Thread(target=work)
        t.start()
        t.join()
        print(*seen, "OPENCV_IPP" in os.environ)
    """
    assert _run(code) == ["False", "False", "False"]


def test_ipp_set_up_before_simroad_is_lost_in_the_importing_thread():
    code = "import cv2; a = cv2.ipp.useIPP(); import simroad.filters; print(a, cv2.ipp.useIPP())"
    assert _run(code) == ["True", "False"]


def test_a_reset_switches_ipp_off_on_its_own_thread():
    code = """
        import threading
        import cv2
        cv2.ipp.useIPP()  # OpenCV has set IPP up before simroad loads: per thread only
        from simroad.envs import RoadCamEnv
        seen = []
        def work():
            seen.append(cv2.ipp.useIPP())  # a new thread starts with OpenCV's default
            RoadCamEnv(scenario="racetrack", width=64, height=36).reset(seed=0)
            seen.append(cv2.ipp.useIPP())
        t = threading.Thread(target=work)
        t.start()
        t.join()
        print(*seen, cv2.ipp.useIPP())
    """
    assert _run(code) == ["True", "False", "False"]


def test_an_opencv_ipp_of_the_users_own_is_kept():
    assert _run("import simroad, cv2; print(cv2.ipp.useIPP())", OPENCV_IPP="sse42") == ["True"]
