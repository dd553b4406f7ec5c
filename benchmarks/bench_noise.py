"""Weather models per 320x180 frame on one core, against albumentations' heuristics.

Each simroad model runs as in an episode (state advancing by 1/15 s per frame, the
ego at 15 m/s) on a rendered racetrack frame with depth and materials; the
albumentations transform that imitates the same weather runs on the same frame,
interleaved. Target: every model <= 2 ms median at any severity.

albumentations is a bench-only extra (``pip install simroad[bench]``); the package
never imports it.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
from _harness import interleaved, one_core, table

from simroad.experiments.scene import SCENE_EGO_SPEED_M_S, sample_scene
from simroad.noise import NoiseContext, make_weather

TARGET_MS = 2.0
SEVERITIES = (0.5, 1.0)


def _albumentations() -> dict:
    try:
        import albumentations as A
    except ImportError:  # pragma: no cover - bench extra missing
        return {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {
            "rain": A.RandomRain(p=1.0),
            "snow": A.RandomSnow(p=1.0),
            "shadow": A.RandomShadow(p=1.0),
            "glare": A.RandomSunFlare(p=1.0),
            "fog": A.RandomFog(p=1.0),
        }


def _simroad_step(weather, frame, ctx_kw: dict):
    state = {"t": 0.0}

    def step():
        state["t"] += 1 / 15
        return weather.apply(frame.rgb, NoiseContext(time_s=state["t"], **ctx_kw))

    return step


def main(repeats: int = 200) -> dict[str, dict[str, np.ndarray]]:
    """Print one table per noise; return the raw timings (seconds per call)."""
    one_core()
    frame, cam, world = sample_scene(seed=0)
    ctx_kw = dict(
        camera=cam,
        depth=frame.depth,
        material=frame.material,
        vehicles=frame.vehicles,
        ego_speed=SCENE_EGO_SPEED_M_S,
        dt=1 / 15,
    )
    alb = _albumentations()
    results = {}
    for name in ("rain", "snow", "shadow", "glare", "fog"):
        cands, targets = {}, {}
        for s in SEVERITIES:
            weather = make_weather(name, severity=s)
            weather.reset(np.random.default_rng(0), world=world)
            label = f"simroad {name} (severity {s:g})"
            cands[label] = _simroad_step(weather, frame, ctx_kw)
            targets[label] = TARGET_MS
        base = None
        if name in alb:
            base = f"albumentations {type(alb[name]).__name__}"
            tf = alb[name]
            cands[base] = lambda tf=tf: tf(image=frame.rgb)["image"]
        times = interleaved(cands, repeats=repeats)
        print(table(f"{name}: 320x180, one core", times, baseline=base, target_ms=targets), flush=True)
        results[name] = times
    return results


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
