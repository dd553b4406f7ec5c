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

    # Scenery-like meshes: 40 boxes (2-10 m tall) beside the road, over the same frames.
    from simroad.camera.mesh import Mesh
    from simroad.camera.vehicles import box_mesh
    from simroad.camera.world import BUILDING

    class _Boxes:
        def __init__(self, mesh: Mesh) -> None:
            self.mesh = mesh

        def meshes(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Mesh:
            v = self.mesh.vertices[:, 0]
            keep = (v[:, 0] >= xmin) & (v[:, 0] <= xmax) & (v[:, 1] >= ymin) & (v[:, 1] <= ymax)
            return self.mesh.select(np.isin(self.mesh.solid, np.unique(self.mesh.solid[keep])))

    def scenery(env):
        rng = np.random.default_rng(0)
        road = env.highway_env.road
        boxes = []
        for lane in road.network.lanes_list():
            for s in np.arange(0.0, lane.length, 6.0):
                side = 1.0 if rng.random() < 0.5 else -1.0
                x, y = lane.position(float(s), side * (lane.width_at(float(s)) / 2 + 4.0 + 3.0 * rng.random()))
                boxes.append(
                    box_mesh(
                        float(x),
                        float(y),
                        float(rng.uniform(0, np.pi)),
                        *rng.uniform(1.0, 5.0, 2),
                        0.0,
                        float(rng.uniform(2.0, 10.0)),
                        albedo=(0.3, 0.3, 0.3),
                        material=BUILDING,
                    )
                )
        return _Boxes(Mesh.concat(boxes))

    small_s = RoadCamEnv(scenario="racetrack")
    small_s.reset(seed=0)
    small_s.world.scenery = scenery(small_s)
    big_s = RoadCamEnv(scenario="racetrack", width=1280, height=720)
    big_s.reset(seed=0)
    big_s.world.scenery = small_s.world.scenery

    times = interleaved(
        {
            "highway-env env.step() (bare, racetrack)": bare_racetrack_step(),
            "highway-env env.render() (600x600 top-down)": hw_render,
            "simroad camera frame + GT 320x180": cam(small),
            "simroad camera frame + GT 1280x720": cam(big),
            "camera + GT + boxes beside the road 320x180": cam(small_s),
            "camera + GT + boxes beside the road 1280x720": cam(big_s),
        },
        repeats=60,
    )
    print(
        table(
            "camera frame + ground truth, one core (ratio vs one bare env.step)",
            times,
            baseline="highway-env env.step() (bare, racetrack)",
            target_ms={
                "simroad camera frame + GT 320x180": 3.0,
                "simroad camera frame + GT 1280x720": 25.0,
                "camera + GT + boxes beside the road 320x180": 3.0,
                "camera + GT + boxes beside the road 1280x720": 25.0,
            },
        )
    )
    r = times["highway-env env.render() (600x600 top-down)"]
    c = times["simroad camera frame + GT 320x180"]
    print(f"camera 320x180 vs highway-env render(): {np.median(r) / np.median(c):.1f}x faster")


if __name__ == "__main__":
    main()
