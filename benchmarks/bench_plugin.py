"""What a plug-in detector costs the closed loop beyond its own predict(): a detector
that returns a constant mask, loaded by file spec (simroad.detector.registry) and driven
by the MaskDriver, against the same controller fed the same mask directly (the built-in
path's bookkeeping without the plug-in layer), side by side."""

from __future__ import annotations

import tempfile
import textwrap
from pathlib import Path

import numpy as np
from _harness import interleaved, one_core, table

CONSTANT = textwrap.dedent(
    """
    import numpy as np

    class Constant:
        name = "constant"

        def __init__(self, height=180, width=320):
            self.mask = np.zeros((height, width), bool)
            self.mask[height // 2 :, width // 4 : 3 * width // 4] = True

        def predict(self, image):
            return self.mask
    """
)


def main() -> None:
    one_core()
    from simroad.control.config import ControllerConfig
    from simroad.control.drivers import MaskDriver
    from simroad.detector.registry import load_detector
    from simroad.envs import RoadCamEnv, get_scenario

    env = RoadCamEnv(scenario="racetrack", longitudinal=True)
    obs, info = env.reset(seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "constant.py"
        path.write_text(CONSTANT)
        detector = load_detector(f"{path}:Constant")
        control = ControllerConfig.for_scenario(get_scenario("racetrack"))
        plugged = MaskDriver(env.camera, control, detector=detector)
        bare = MaskDriver(env.camera, control)  # the controller alone, fed the mask
        mask = detector.mask
        speed = float(info["speed_m_s"])
        given = {"road_mask": mask, "speed_m_s": speed}

        def plug_in():
            plugged(obs, info)

        def built_in():
            bare(obs, given)

        times = interleaved({"controller fed the mask (no plug-in layer)": built_in,
                             "constant plug-in detector by file spec": plug_in}, repeats=400)  # fmt: skip
    print(table("a plug-in detector's cost per policy step, one core", times,
                baseline="controller fed the mask (no plug-in layer)"))  # fmt: skip
    extra = np.median(times["constant plug-in detector by file spec"]) - np.median(
        times["controller fed the mask (no plug-in layer)"]
    )
    print(f"plug-in layer: {1e3 * extra:+.4f} ms per step (target <= 0.05 ms)")


if __name__ == "__main__":
    main()
