"""The same seed gives the same frames and numbers on any machine: pinned digests.

Frames of two worlds (SHA-256 of the images and road masks) and one closed-loop
episode's record are pinned in ``data/reproducible.json``. A change of behaviour
fails here on purpose: when you change the rendering, the weather, the detector or the
dynamics deliberately, regenerate the file with
``python tests/experiments/test_reproducible.py --update`` and say why in the commit.
A change that depends on the machine (CPU features, thread counts, library builds)
fails here too: the second test reruns everything with NumPy's AVX2/FMA kernels
disabled, OpenCV's kernels for the baseline SSE3 only, Numba compiling for a generic
x86-64 and one thread everywhere. (OpenCV's IPP path rounds by the CPU's vector width:
simroad switches it off, :mod:`simroad.core.opencv`.)
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

PINNED = Path(__file__).parent / "data" / "reproducible.json"
#: Record keys that vary by run (timings) or by release (the version string).
UNPINNED = ("detect_ms_median", "step_ms_median", "wall_s", "detector_version")
#: A machine as unlike this one as a single process can make it.
OTHER_MACHINE = {
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",  # no AVX2/FMA3/AVX-512 in NumPy's kernels
    "OPENCV_CPU_DISABLE": "AVX512-SKX,AVX2,FP16,AVX,SSE4.2,SSE4.1",  # OpenCV's baseline kernels only
    "NUMBA_CPU_NAME": "generic",  # Numba's kernels for any x86-64
    "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1",
}  # fmt: skip


def fingerprint() -> dict:
    """Digests of three steps of two worlds under weather, and one episode's record."""
    from simroad.envs import RoadCamEnv
    from simroad.experiments.episode import EpisodeSpec, run_episode

    frames = {}
    for scenario, noise in (("racetrack", "rain+glare"), ("town", "snow")):
        env = RoadCamEnv(scenario=scenario, noise=noise, severity=0.7)
        obs, info = env.reset(seed=7)
        digest = hashlib.sha256()
        for _ in range(3):
            digest.update(np.ascontiguousarray(obs).tobytes())
            digest.update(np.ascontiguousarray(info["road_mask"]).tobytes())
            obs, _, _, _, info = env.step(np.zeros(env.action_space.shape, dtype=env.action_space.dtype))
        env.close()
        frames[f"{scenario}/{noise}"] = digest.hexdigest()
    spec = EpisodeSpec(scenario="racetrack", noise="glare", severity=0.5, filters="all", seed=2, steps=20)
    record = {k: v for k, v in run_episode(spec).items() if k not in UNPINNED}
    return {"frames": frames, "episode": json.loads(json.dumps(record))}


def _compare(got: dict, pinned: dict) -> list[str]:
    wrong = [
        f"frames {k}: {got['frames'].get(k)} != {v}" for k, v in pinned["frames"].items() if got["frames"].get(k) != v
    ]
    wrong += [f"episode {k}: {got['episode'].get(k)!r} != {v!r}" for k, v in pinned["episode"].items()
              if got["episode"].get(k) != v]  # fmt: skip
    return wrong


def test_the_frames_and_an_episode_are_the_pinned_ones():
    wrong = _compare(fingerprint(), json.loads(PINNED.read_text()))
    assert not wrong, "changed (regenerate deliberately, see the module docstring): " + "; ".join(wrong)


@pytest.mark.slow
def test_the_same_on_a_generic_cpu_with_one_thread():
    """Numba recompiles once for the generic CPU (its cache keeps both builds)."""
    env = {**os.environ, **OTHER_MACHINE}
    run = subprocess.run([sys.executable, __file__], capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    wrong = _compare(json.loads(run.stdout), json.loads(PINNED.read_text()))
    assert not wrong, "differs on another machine: " + "; ".join(wrong)


if __name__ == "__main__":
    result = fingerprint()
    if sys.argv[1:] == ["--update"]:
        PINNED.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {PINNED}")
    else:
        print(json.dumps(result))
