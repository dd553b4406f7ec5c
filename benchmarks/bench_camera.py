"""Camera frame + ground truth (with the world's scenery, the vehicles and the sensor)
vs highway-env's own render() and one bare env.step()."""

from __future__ import annotations

import numpy as np
from _harness import bare_racetrack_step, interleaved, one_core, table

SCENARIOS = ("racetrack", "highway", "winding", "town")
# width, height, the target (ms) with the sensor, the renderer's share of it
SIZES = ((320, 180, 3.0, 1.2), (1280, 720, 25.0, 12.0))


def main() -> None:
    one_core()
    import gymnasium as gym
    import highway_env  # noqa: F401

    import simroad  # noqa: F401
    from simroad.envs import RoadCamEnv
    from simroad.experiments.rollout import autopilot_env_action

    hw = gym.make("racetrack-v0", render_mode="rgb_array", config={"offscreen_rendering": True}).unwrapped
    hw.reset(seed=0)

    def frame(env, poses, sensor=True):
        """The env's own renderer (its world's scenery at the default density, the
        other vehicles) and its sensor, over poses along the route."""
        it = {"k": 0}

        def run():
            pose, others, speed = poses[it["k"] % len(poses)]
            it["k"] += 1
            if sensor:  # as the env does: the ground blurred in the texture, the rest by the sensor
                fr = env.renderer.render(pose, others, motion_m=env.sensor.travel_m(speed))
                env.sensor.apply(fr.rgb, speed_m_s=speed, depth=fr.depth, face_id=fr.face_id)
            else:
                fr = env.renderer.render(pose, others)

        return run

    base = "highway-env env.step() (bare, racetrack)"
    groups: dict[tuple[int, int], dict] = {(w, h): {base: bare_racetrack_step()} for w, h, _, _ in SIZES}
    groups[(320, 180)]["highway-env env.render() (600x600 top-down)"] = hw.render
    targets = {}
    for sc in SCENARIOS:
        small = RoadCamEnv(scenario=sc)
        small.reset(seed=0)
        poses = []
        for _ in range(40):  # poses along the route, re-used at every size
            small.step(autopilot_env_action(small))
            poses.append((small._pose(), small._others(), float(small.vehicle.speed)))
        for w, h, target, target_render in SIZES:
            env = small if (w, h) == (320, 180) else RoadCamEnv(scenario=sc, width=w, height=h)
            if env is not small:
                env.reset(seed=0)
            name = f"{sc}: frame + GT + sensor {w}x{h}"
            groups[(w, h)][name] = frame(env, poses)
            targets[name] = target
            name = f"{sc}: frame + GT (renderer only) {w}x{h}"
            groups[(w, h)][name] = frame(env, poses, sensor=False)
            targets[name] = target_render
    # Each size side by side with the baseline in its own run: a 1280x720 frame
    # between two small ones would evict the small ones' working set from the cache.
    for (w, h), candidates in groups.items():
        times = interleaved(candidates, repeats=40)
        print(
            table(
                f"camera frame + ground truth + sensor at {w}x{h}, scenery and vehicles, one core "
                "(ratio vs one bare env.step)",
                times,
                baseline=base,
                target_ms=targets,
            )
        )
        if (w, h) == (320, 180):
            r = times["highway-env env.render() (600x600 top-down)"]
            c = times[f"{SCENARIOS[0]}: frame + GT + sensor 320x180"]
            print(f"camera 320x180 ({SCENARIOS[0]}) vs highway-env render(): {np.median(r) / np.median(c):.1f}x faster")


if __name__ == "__main__":
    main()
