"""Camera frame + ground truth vs highway-env's own render() and one bare env.step()."""

from __future__ import annotations

import numpy as np
from _harness import bare_racetrack_step, interleaved, one_core, table


def main() -> None:
    one_core()
    import gymnasium as gym
    import highway_env  # noqa: F401

    import simroad  # noqa: F401
    from simroad.envs import RoadCamEnv
    from simroad.experiments.rollout import autopilot_env_action

    small = RoadCamEnv(scenario="racetrack")
    small.reset(seed=0)
    big = RoadCamEnv(scenario="racetrack", width=1280, height=720)
    big.reset(seed=0)
    hw = gym.make("racetrack-v0", render_mode="rgb_array", config={"offscreen_rendering": True}).unwrapped
    hw.reset(seed=0)

    poses = []
    for _ in range(40):  # poses along a lap, re-used by every candidate
        small.step(autopilot_env_action(small))
        poses.append((small._pose(), small._others()))
    it = {"k": 0}

    def cam(env):
        def run():
            pose, others = poses[it["k"] % len(poses)]
            it["k"] += 1
            env.renderer.render(pose, others)

        return run

    def hw_render():
        hw.render()

    times = interleaved(
        {
            "highway-env env.step() (bare, racetrack)": bare_racetrack_step(),
            "highway-env env.render() (600x600 top-down)": hw_render,
            "simroad camera frame + GT 320x180": cam(small),
            "simroad camera frame + GT 1280x720": cam(big),
        },
        repeats=60,
    )
    print(
        table(
            "camera frame + ground truth, one core (ratio vs one bare env.step)",
            times,
            baseline="highway-env env.step() (bare, racetrack)",
            target_ms={"simroad camera frame + GT 320x180": 3.0, "simroad camera frame + GT 1280x720": 25.0},
        )
    )
    r = times["highway-env env.render() (600x600 top-down)"]
    c = times["simroad camera frame + GT 320x180"]
    print(f"camera 320x180 vs highway-env render(): {np.median(r) / np.median(c):.1f}x faster")


if __name__ == "__main__":
    main()
