"""The camera sensor (camera_effects) vs the bare camera frame it follows, side by side.

The sensor is called as :class:`simroad.envs.RoadCamEnv` calls it, with the renderer's
face ids: the renderer has motion-blurred the ground in its texture, so the sensor blurs
only the objects. A row without face ids times the image-space blur of every pixel (what a
frame from elsewhere gets); it has no target.
"""

from __future__ import annotations

import numpy as np
from _harness import interleaved, one_core, table


def _scene(width: int, height: int):
    """A highway frame after a few steps at speed: (renderer call, frame, env)."""
    from simroad.envs import RoadCamEnv

    env = RoadCamEnv(scenario="highway", width=width, height=height, camera_effects=False)
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.zeros(1, np.float32))
    pose, others = env._pose(), env._others()
    frame = env.renderer.render(pose, others)
    return (lambda: env.renderer.render(pose, others)), frame, env


def main() -> None:
    one_core()
    import dataclasses

    from simroad.camera.sensor import Sensor
    from simroad.camera.sensor_params import SensorParams

    for (w, h), target in (((320, 180), 0.7), ((1280, 720), 8.0)):
        render, frame, env = _scene(w, h)
        speed = float(env.vehicle.speed)
        candidates = {f"camera frame + GT {w}x{h} (bare renderer)": render}
        for name, params in (
            ("sensor, default (all effects)", SensorParams()),
            ("sensor, no motion blur", dataclasses.replace(SensorParams(), motion_blur=False)),
            ("sensor, JPEG q=90", SensorParams(jpeg_quality=90)),
        ):
            sensor = Sensor(params, env.camera)
            sensor.reset(np.random.default_rng(0))
            sensor.apply(frame.rgb, speed_m_s=speed, depth=frame.depth)  # settles the exposure
            settled = sensor.ev

            def run(s=sensor, f=frame, v=speed, ev=settled):
                s.ev = ev  # the settled exposure every call
                s.apply(f.rgb, speed_m_s=v, depth=f.depth, face_id=f.face_id)  # as RoadCamEnv calls it

            candidates[f"{name} {w}x{h}"] = run
            if name.startswith("sensor, default"):
                # without the renderer's face ids every pixel is blurred in image space (a
                # photograph or a user's frame); the renderer blurs the ground in its texture

                def run_all(s=sensor, f=frame, v=speed, ev=settled):
                    s.ev = ev
                    s.apply(f.rgb, speed_m_s=v, depth=f.depth)

                candidates[f"sensor, default, every pixel blurred {w}x{h}"] = run_all
        times = interleaved(candidates, repeats=40 if w > 320 else 150)
        print(
            table(
                f"camera sensor at {w}x{h}, one core (ratio vs the bare camera frame, {speed:.0f} m/s)",
                times,
                baseline=f"camera frame + GT {w}x{h} (bare renderer)",
                target_ms={f"sensor, default (all effects) {w}x{h}": target},
            )
        )


if __name__ == "__main__":
    main()
