"""The main job, ``make demo``: a short clean episode rendered to frames and a GIF."""

from __future__ import annotations

import argparse
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
from tqdm import tqdm

from simroad.envs import RoadCamEnv
from simroad.experiments.export import ensure_writable_dir, export_frames

__all__ = ["run_demo"]


def run_demo(out: str | Path, *, seed: int = 0, steps: int = 60) -> Path:
    """Write ``out/frames`` (frames + GT masks + meta.json) and ``out/episode.gif``."""
    out = ensure_writable_dir("out", out)
    export_frames(out / "frames", seed=seed, count=steps, env_kwargs={"scenario": "racetrack"}, progress=True)
    env = RoadCamEnv(scenario="winding", render_mode="rgb_array")
    env.reset(seed=seed)
    images = []
    for _ in tqdm(range(steps), desc="episode.gif", unit="step"):
        env.step(env.autopilot_action())
        cam = env.render()
        bev = env.render_bev(size=(90, cam.shape[0]), metres_per_px=0.5)
        images.append(np.hstack([cam, bev]))
    imageio.mimsave(out / "episode.gif", images, duration=0.2, loop=0)
    env.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="runs/demo")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    out = run_demo(args.out, seed=args.seed)
    print(f"demo written to {out}/ (frames/, episode.gif)")


if __name__ == "__main__":
    main()
