"""simroad: a closed-loop simulation testbed for camera road detection in bad weather.

``import simroad`` registers the gymnasium environment ``simroad/RoadCam-v0``.
"""

from __future__ import annotations

import os

# Headless by default: highway-env imports pygame, which must never look for a display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

from simroad._validation import SimroadError
from simroad.envs import ENV_ID, RoadCamConfig, RoadCamEnv

__version__ = "0.1.0"
__all__ = ["ENV_ID", "RoadCamConfig", "RoadCamEnv", "SimroadError", "__version__"]
