"""Closed loop at 320x180 on the racetrack: policy steps per second of the detector
driver, and perception + control cost per step as a ratio to highway-env's own step."""

from __future__ import annotations

import numpy as np
from _harness import bare_racetrack_step, interleaved, one_core, table


def main() -> None:
    one_core()

    from simroad.control.drivers import make_driver
    from simroad.envs import RoadCamEnv

    env = RoadCamEnv(scenario="racetrack", longitudinal=True)
    obs, info = env.reset(seed=0)
    driver = make_driver("detector", env, filters=("shadow", "rain_snow", "light"))
    driver.reset()
    state = {"obs": obs, "info": info}

    def full_step():
        action = driver(state["obs"], state["info"])
        obs, _, term, trunc, info = env.step(action)
        if term or trunc:
            obs, info = env.reset(seed=1)
            driver.reset()
        state["obs"], state["info"] = obs, info

    def perception_control():
        mask = driver.episode.predict(state["obs"])
        driver.controller.act(mask, float(state["info"]["speed_m_s"]))

    def camera():
        env._observe(crashed=False)

    times = interleaved(
        {
            "highway-env env.step() (bare, racetrack)": bare_racetrack_step(),
            "camera frame + GT (RoadCam observation)": camera,
            "perception + control (detector, all filters)": perception_control,
            "full detector-driver step (all of the above)": full_step,
        },
        repeats=80,
    )
    print(
        table(
            "closed loop, 320x180, racetrack, one core (ratio vs bare env.step)",
            times,
            baseline="highway-env env.step() (bare, racetrack)",
        )
    )
    full = float(np.median(times["full detector-driver step (all of the above)"]))
    pc = float(np.median(times["perception + control (detector, all filters)"]))
    hw = float(np.median(times["highway-env env.step() (bare, racetrack)"]))
    print(f"detector driver: {1.0 / full:.1f} policy steps/s (target >= 30)")
    print(f"perception + control cost per step = {pc / hw:.2f} x highway-env's own step")


if __name__ == "__main__":
    main()
