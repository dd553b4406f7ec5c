"""simroad: a closed-loop simulation testbed for camera road detection in bad weather.

``import simroad`` registers the gymnasium environment :data:`ENV_ID`
(``simroad/RoadCam-v0``) by its entry-point string: the simulator is imported only
when ``gymnasium.make`` builds the environment, so importing a filter or the
detector loads neither gymnasium nor highway-env. If gymnasium is not imported yet,
the registration is made the moment it is.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys
from collections.abc import Sequence
from types import ModuleType

# Headless by default: highway-env imports pygame, which must never look for a display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

from simroad.core.opencv import opencv_without_ipp
from simroad.errors import SimroadError

# The same frames on every CPU: OpenCV's IPP path rounds by the CPU's vector width.
opencv_without_ipp()

__version__ = "0.2.0.dev0"
__all__ = ["ENV_ID", "SimroadError", "__version__"]

#: The gymnasium id of :class:`simroad.envs.RoadCamEnv`.
ENV_ID = "simroad/RoadCam-v0"
_ENTRY_POINT = "simroad.envs.roadcam:RoadCamEnv"


def _register(registration: ModuleType) -> None:
    if ENV_ID not in registration.registry:
        registration.register(id=ENV_ID, entry_point=_ENTRY_POINT)


class _RegisterWhenGymnasiumLoads(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Registers :data:`ENV_ID` right after ``gymnasium.envs.registration`` has loaded.

    A one-shot import hook: it finds the module with the regular finders, runs it, adds
    the registration, and removes itself.
    """

    _NAME = "gymnasium.envs.registration"

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname != self._NAME:
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return spec
        self._loader = spec.loader
        spec.loader = self
        return spec

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self._loader.exec_module(module)
        _register(module)


if "gymnasium.envs.registration" in sys.modules:
    _register(sys.modules["gymnasium.envs.registration"])
elif not any(isinstance(hook, _RegisterWhenGymnasiumLoads) for hook in sys.meta_path):
    sys.meta_path.insert(0, _RegisterWhenGymnasiumLoads())
