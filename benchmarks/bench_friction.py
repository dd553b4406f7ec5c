"""What tyre–road friction costs a policy step (target: at most 10 %): the same
closed-loop step (render, weather, sensor, oracle driver, highway-env with traffic)
with friction on and off, side by side; and highway-env's own step alone, where the
friction circle, the μ look-ups and the traffic's grip planning all happen."""

from __future__ import annotations

import numpy as np
from _harness import interleaved, one_core, table

#: (scenario, noise, extra weather parameters): the busiest traffic (highway, 16
#: cars), and settled snow on the road (a μ look-up per car and physics step).
CASES = (("highway", "rain", None), ("winding", "snow", "patches"))


def _stepper(scenario: str, noise: str, patches: str | None, friction: bool):
    from simroad.control import make_driver
    from simroad.envs import RoadCamEnv
    from simroad.noise import SnowParams

    params = {"snow": SnowParams(settle=0.7, settle_on_road=True)} if patches else None
    env = RoadCamEnv(scenario=scenario, noise=noise, severity=0.8, longitudinal=True, friction=friction,
                     noise_params=params)  # fmt: skip
    driver = make_driver("oracle", env)
    state = {}

    def reset() -> None:
        state["obs"], state["info"] = env.reset(seed=0)
        driver.reset()

    def step() -> None:
        obs, _, terminated, truncated, info = env.step(driver(state["obs"], state["info"]))
        state["obs"], state["info"] = obs, info
        if terminated or truncated:
            reset()

    def physics() -> None:
        env.highway_env.step(np.array([0.0, 0.0], dtype=np.float32))
        if env.vehicle.crashed or env.highway_env.time > 30.0:
            reset()

    reset()
    return step, physics


def main() -> None:
    one_core()
    for scenario, noise, patches in CASES:
        label = f"{scenario}, {noise} 0.8" + (" with snow on the road" if patches else "")
        on_step, on_phys = _stepper(scenario, noise, patches, True)
        off_step, off_phys = _stepper(scenario, noise, patches, False)
        times = interleaved({"policy step, friction off": off_step, "policy step, friction on": on_step}, repeats=60)
        print(table(f"{label}: one policy step (320x180, oracle), one core", times,
                    baseline="policy step, friction off"))  # fmt: skip
        added = np.median(times["policy step, friction on"]) / np.median(times["policy step, friction off"]) - 1
        print(f"friction adds {100 * added:+.1f} % to a policy step (target <= 10 %)")
        phys = interleaved({"highway-env step, friction off": off_phys, "highway-env step, friction on": on_phys},
                           repeats=200)  # fmt: skip
        print(table(f"{label}: highway-env's step alone (3 physics steps)", phys,
                    baseline="highway-env step, friction off"))  # fmt: skip


if __name__ == "__main__":
    main()
