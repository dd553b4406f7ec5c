"""Does ``simroad calibrate`` recover a known camera profile? (issue 30 item 4's acceptance check)

1. "Photos": clear frames that simroad renders with a known non-default profile, one
   frame per world (``--photo-worlds`` worlds per scenario), written as PNG with
   their road masks.
2. ``calibrate_from_photos`` on them, rendering OTHER worlds for every evaluation.
3. Check: one frame per world of yet other worlds (``--check-worlds`` per scenario),
   rendered with the fitted profile, with the true one (the noise floor: the KS
   distance two samples of this size show for the same distribution) and with the
   default one; the two-sample KS distance of each statistic to the photos.

The bar: KS <= 0.15 on every statistic between the fitted profile's frames and the
photos. With 400 photos against 200 check frames the 5 % critical value of the
two-sample KS test is 0.118 (0.136 with 200 photos), so the bar is met only when the
fit is close. 400 photos by default: with 200 the fit settled on a flatter tone curve
and a darker asphalt that the objective scored better than the truth on those photos
(road spread and road - surround KS 0.17). Not part of ``make bench`` (it takes tens of
minutes); run it directly::

    python benchmarks/calibration_check.py --out runs/calibration-check
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from simroad.camera.profile import CameraProfile
from simroad.envs import SCENARIO_NAMES
from simroad.experiments.calibrate import calibrate_from_photos, format_calibration, ks_distances, write_calibration
from simroad.experiments.frames import collect_frames
from simroad.experiments.pool import default_workers, run_in_workers
from simroad.metrics.appearance import STATISTICS, frame_appearance

TRUTH = CameraProfile(exposure_bias_ev=0.8, wb_preset_k=4200.0, tone_gamma=1.3, asphalt_scale=1.4)
BAR = 0.15


def _world_frames(item: tuple[CameraProfile, int]) -> tuple[int, list, list, list]:
    """The second frame (five policy steps in, the exposure settled) of every scenario
    in world ``seed``: the seed, images, masks and statistics (frames without road left out)."""
    profile, seed = item
    fs = collect_frames(
        scenarios=SCENARIO_NAMES, seeds=(seed,), frames_per_seed=2, every=5, env_options={"camera_profile": profile}
    )
    images, masks, rows = [], [], []
    for rgb, road, src in zip(fs.images, fs.masks, fs.source):
        stats = frame_appearance(rgb, road) if src[2] > 0 else None
        if stats is not None:
            images.append(rgb)
            masks.append(road)
            rows.append(stats)
    return seed, images, masks, rows


def one_frame_per_world(profile: CameraProfile, seeds: range) -> tuple[list, list, dict[str, np.ndarray]]:
    """:func:`_world_frames` of every seed, on every core, in seed order (the env's own
    frames: the check renders real episodes, not replays)."""
    done = {
        seed: rest
        for seed, *rest in run_in_workers([(profile, int(s)) for s in seeds], default_workers(), _world_frames)
    }
    images, masks, rows = [], [], []
    for seed in sorted(done):
        a, b, c = done[seed]
        images += a
        masks += b
        rows += c
    return images, masks, {s: np.array([r[s] for r in rows]) for s in STATISTICS}


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--photo-worlds", type=int, default=100, help="worlds per scenario for the photos (default 100)")
    p.add_argument("--check-worlds", type=int, default=50, help="worlds per scenario for the check (default 50)")
    p.add_argument("--fit-seeds", type=int, default=50, help="worlds per scenario per evaluation (default 50)")
    p.add_argument("--fit-frames", type=int, default=1, help="frames per world per evaluation (default 1)")
    p.add_argument("--max-evaluations", type=int, default=24, help="renders of the fit's worlds at most")
    p.add_argument("--max-replays", type=int, default=200, help="profiles scored from recorded renders at most")
    p.add_argument("--fit", default="exposure_bias_ev,wb_preset_k,tone_gamma,asphalt_scale")
    p.add_argument("--out", type=Path, default=Path("runs/calibration-check"))
    p.add_argument(
        "--check", default="fitted,true,default", help="profiles to check: fitted, true (the noise floor), default"
    )
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    timings = {}
    t0 = time.perf_counter()
    images, masks, photo_values = one_frame_per_world(TRUTH, range(20_000, 20_000 + args.photo_worlds))
    timings["photos_s"] = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        pdir, mdir = Path(tmp, "photos"), Path(tmp, "masks")
        pdir.mkdir()
        mdir.mkdir()
        for i, (rgb, road) in enumerate(zip(images, masks)):
            cv2.imwrite(str(pdir / f"p{i:04d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
            cv2.imwrite(str(mdir / f"p{i:04d}.png"), road.astype(np.uint8) * 255)
        t0 = time.perf_counter()
        result = calibrate_from_photos(
            pdir,
            mdir,
            fit=tuple(f.strip() for f in args.fit.split(",")),
            seeds=range(6000, 6000 + args.fit_seeds),
            frames=args.fit_frames,
            max_evaluations=args.max_evaluations,
            max_replays=args.max_replays,
            progress=True,
        )
        timings["fit_s"] = time.perf_counter() - t0
    print(format_calibration(result), flush=True)
    write_calibration(result, args.out / "fitted.toml")
    t0 = time.perf_counter()
    check = range(30_000, 30_000 + args.check_worlds)
    profiles = {"fitted": result.profile, "true": TRUTH, "default": CameraProfile()}
    wanted = [c.strip() for c in args.check.split(",")]
    ks = {name: ks_distances(one_frame_per_world(profiles[name], check)[2], photo_values) for name in wanted}
    timings["check_s"] = time.perf_counter() - t0
    n_photos = int(photo_values["road_V"].size)
    print(f"\nKS to the {n_photos} photos, {args.check_worlds} check worlds per scenario (bar {BAR}):")
    print(f"{'statistic':<20}" + "".join(f"  {name:>7}" for name in ks))
    for s in STATISTICS:
        print(f"{s:<20}" + "".join(f"  {ks[name][s]:7.3f}" for name in ks))
    passed = all(ks["fitted"][s] <= BAR for s in STATISTICS)
    fields = {f: {"true": getattr(TRUTH, f), "default": getattr(CameraProfile(), f), "fitted": getattr(result.profile, f)}
              for f in result.fitted}  # fmt: skip
    for f, v in fields.items():
        print(f"{f:<20} true {v['true']!s:>10}  default {v['default']!s:>10}  fitted {v['fitted']!s:>10}")
    print(
        f"objective {result.start_objective:.3f} -> {result.objective:.3f}; "
        f"{result.evaluations} evaluations, {result.renders} renders"
    )
    print("timings (s): " + ", ".join(f"{k} {v:.0f}" for k, v in timings.items()))
    print("PASS" if passed else "FAIL", f"(every statistic's KS <= {BAR})")
    summary = {
        "photos": n_photos,
        "ks": ks,
        "fields": fields,
        "objective": [result.start_objective, result.objective],
        "evaluations": result.evaluations,
        "renders": result.renders,
        "frames_per_evaluation": result.frames,
        "timings_s": timings,
        "passed": passed,
    }
    (args.out / "calibration_check.json").write_text(json.dumps(summary, indent=1, default=list) + "\n")
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
