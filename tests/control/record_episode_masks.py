"""Record ``data/glare_episode_masks.json``, the masks test_episode_masks.py holds the
detector to, with the renderer and the shipped model of this checkout.

Run it when the frames or the shipped model change on purpose (the camera's look, a
retrained detector), never to make a failing mask test pass: the test exists to show
that a refactor of the detector left its masks as they were::

    python tests/control/record_episode_masks.py
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

from test_episode_masks import SETTINGS, frame_hash, glare_loop, mask_hash  # noqa: E402

from simroad.detector import RoadDetector  # noqa: E402
from simroad.experiments.frames import collect_frames  # noqa: E402
from simroad.filters import FILTERS  # noqa: E402

LOOPS = ("winding/0/0.7", "racetrack/0/0.8")
STEPS = 40


def loop(key: str) -> dict[str, list[str]]:
    hashes = list(glare_loop(key, STEPS))
    return {"frames": [f for f, _ in hashes], "masks": [m for _, m in hashes]}


def sequence() -> dict:
    glare = collect_frames(scenarios=("highway",), seeds=[7], frames_per_seed=1, noise="glare", severity=0.8).images[0]
    clear = collect_frames(scenarios=("town",), seeds=[7], frames_per_seed=1).images[0]
    fs = collect_frames(scenarios=("winding",), seeds=[0], frames_per_seed=1, noise="glare", severity=0.7, every=8)
    sun, ground = fs.images[0], fs.valid[0]

    class Camera:
        ground_valid = ground

    frames = [clear, glare] + [clear] * 22 + [sun, clear, clear, glare, clear]
    out: dict = {"frames": [frame_hash(a) for a in (clear, glare, sun, ground)]}
    for name, camera in (("nocamera", None), ("camera", Camera())):
        rec = {}
        for setting, options in SETTINGS.items():
            episode = RoadDetector.pretrained(**options).episode(camera)
            rec[setting] = [mask_hash(episode.predict(f)) for f in frames]
        episode = RoadDetector.pretrained(filters=FILTERS).episode(camera)
        rec["all/exact/first3"] = [mask_hash(episode.predict(f, exact=True)) for f in frames[:3]]
        out[name] = rec
    return out


def main() -> None:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=HERE).stdout
    record = {
        "recorded_at": commit.strip() or "unknown",
        "hash": "first 16 hex digits of sha256(np.packbits(mask) + str(shape)); frames: of sha256(rgb bytes)",
        "loop": {key: loop(key) for key in LOOPS},
        "sequence": sequence(),
    }
    path = HERE / "data" / "glare_episode_masks.json"
    text = json.dumps(record, indent=1)
    text = re.sub(r"\[\s+([^\[\]{}]*?)\s+\]", lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text)
    path.write_text(text + "\n")  # a list of hashes on one line
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
