"""The videos of the main job: one short detector episode per noise.

``make demo`` runs the small ablation of ``experiments/demo.toml`` (tables and
figures in ``runs/demo``), then this module writes ``runs/demo/videos/NOISE.gif``:
the noisy camera view with the predicted road mask (green), the ground-truth
outline (yellow) and a bird's-eye inset with the trajectory.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from simroad.experiments.episode import EpisodeSpec, run_episode
from simroad.experiments.export import ensure_writable_dir

__all__ = ["DEMO_NOISES", "write_videos"]

DEMO_NOISES = ("clear", "rain", "snow", "shadow", "glare")


def write_videos(
    out: str | Path, *, scenario: str = "winding", seed: int = 0, steps: int = 60, severity: float = 0.7
) -> list[Path]:
    """One GIF per noise of the detector driver with all filters."""
    out = ensure_writable_dir("out", out)
    paths = []
    for noise in tqdm(DEMO_NOISES, desc="videos", unit="video"):
        path = out / f"{noise}.gif"
        spec = EpisodeSpec(
            scenario=scenario,
            noise=noise,
            severity=severity,
            filters=("shadow", "rain_snow", "light"),
            seed=seed,
            steps=steps,
            route_m=1e4,
        )
        run_episode(spec, video=str(path))
        paths.append(path)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/demo/videos")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    paths = write_videos(args.out, seed=args.seed)
    print("videos: " + ", ".join(str(p) for p in paths))


if __name__ == "__main__":
    main()
