"""The last worlds built in this process, reused by a reset that would build them again.

A :class:`~simroad.camera.world.WorldRaster` (its lane outlines and ground textures)
and its :class:`~simroad.camera.scenery.Scenery` are pure functions of the road
network's geometry, the world generator's state, the texel size, the palette, the
extra markings and the scenery's options; building them is most of a reset.
gymnasium's ``check_env`` resets twice with one seed, a paired sweep runs several
filter sets on one world, the tests reset the same worlds again and again.

The cache keeps the last :data:`WORLDS` worlds as pristine masters and hands out a
shallow copy of one: the copy shares the master's textures, lane outlines and tile
caches (every tile is a pure function of its index, whichever episode rendered it
first) but has windows of its own (a window's origin depends on the poses it was
asked for, and enters the camera's warp), and no scenery until one is attached. A hit
sets the world generator to the state the build left it in, so every later draw is
the one a fresh build would give.

A network whose lanes hold anything but numbers, arrays, strings and containers of
them (a lane type simroad does not know) is built afresh each time.
"""

from __future__ import annotations

import copy
import enum
import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simroad.camera import WorldRaster
from simroad.camera.palette import Palette
from simroad.camera.scenery import Scenery

__all__ = ["WORLDS", "clear", "scenery", "world"]

#: Worlds kept (each holds its textures and up to ``max_tiles`` rendered tiles, ~0.1-0.2 GB).
WORLDS = 2
_SCENERIES = 2  # sceneries kept per world
_DEPTH = 4  # nesting of a lane's attributes looked into


class _Uncacheable(Exception):
    """A value the key cannot describe exactly."""


@dataclass
class _Entry:
    world: WorldRaster  # the master, never handed out
    rng_state: Mapping[str, Any]  # the world generator's state after the build
    sceneries: OrderedDict[tuple[Any, ...], Scenery] = field(default_factory=OrderedDict)


_cache: OrderedDict[tuple[Any, ...], _Entry] = OrderedDict()
_lock = threading.Lock()


def _canon(value: Any, depth: int = 0) -> Any:
    """An exact, hashable description of ``value`` (types and bits included)."""
    if depth > _DEPTH:
        raise _Uncacheable
    if value is None or isinstance(value, (bool, str, bytes)):
        return (type(value).__name__, value)
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise _Uncacheable
        return ("ndarray", value.dtype.str, value.shape, np.ascontiguousarray(value).tobytes())
    if isinstance(value, np.generic):
        return (type(value).__name__, value.tobytes())
    if isinstance(value, enum.Enum):
        return (type(value).__qualname__, _canon(value.value, depth + 1))
    if isinstance(value, float):
        return (type(value).__name__, value.hex())
    if isinstance(value, int):
        return (type(value).__name__, value)
    if isinstance(value, (tuple, list)):
        return (type(value).__name__, tuple(_canon(v, depth + 1) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple((_canon(k, depth + 1), _canon(v, depth + 1)) for k, v in value.items()))
    if hasattr(value, "__dict__") and not callable(value):
        kind = f"{type(value).__module__}.{type(value).__qualname__}"
        return (kind, _canon(vars(value), depth + 1))
    raise _Uncacheable


def _world_key(network, rng: np.random.Generator, texel_m: float, palette: Palette, extra: Sequence) -> tuple:
    lanes = tuple(_canon(lane) for lane in network.lanes_list())
    state = _canon(rng.bit_generator.state)
    return (lanes, state, float(texel_m).hex(), _canon(palette), _canon(list(extra)))


def _view(master: WorldRaster) -> WorldRaster:
    """A copy of ``master`` sharing its immutable parts and tile caches, with windows of
    its own and no scenery."""
    out = copy.copy(master)
    out._windows = {}
    out.scenery = None
    return out


def world(
    network,
    rng: np.random.Generator,
    *,
    texel_m: float,
    palette: Palette,
    extra_markings: Sequence[np.ndarray] = (),
) -> WorldRaster:
    """``WorldRaster(network, rng, texel_m=..., palette=..., extra_markings=...)``, the
    same world and the same state of ``rng`` afterwards, reused when built before."""
    try:
        key = _world_key(network, rng, texel_m, palette, extra_markings)
    except _Uncacheable:
        return WorldRaster(network, rng, texel_m=texel_m, palette=palette, extra_markings=extra_markings)
    with _lock:
        entry = _cache.get(key)
        if entry is not None:
            _cache.move_to_end(key)
    if entry is None:
        master = WorldRaster(network, rng, texel_m=texel_m, palette=palette, extra_markings=extra_markings)
        entry = _Entry(master, copy.deepcopy(rng.bit_generator.state))
        with _lock:
            _cache[key] = entry
            while len(_cache) > WORLDS:
                _cache.popitem(last=False)
    else:
        rng.bit_generator.state = dict(copy.deepcopy(entry.rng_state))
    return _view(entry.world)


def scenery(world: WorldRaster, seed: int, **options: Any) -> Scenery:
    """``Scenery(world.shapes, seed, **options)``, reused when this cached world built
    it before (the objects of a cell are a pure function of these): a shallow copy
    sharing the master's cell caches, which the episode's references alone keep alive."""
    with _lock:
        entry = next((e for e in _cache.values() if e.world.shapes is world.shapes), None)
    if entry is None:
        return Scenery(world.shapes, seed, **options)
    try:
        key = _canon((int(seed), sorted(options.items())))
    except _Uncacheable:
        return Scenery(world.shapes, seed, **options)
    with _lock:
        found = entry.sceneries.get(key)
        if found is not None:
            entry.sceneries.move_to_end(key)
            return copy.copy(found)
    built = Scenery(world.shapes, seed, **options)
    with _lock:
        entry.sceneries[key] = built
        while len(entry.sceneries) > _SCENERIES:
            entry.sceneries.popitem(last=False)
    return copy.copy(built)


def clear() -> None:
    """Forget every cached world."""
    with _lock:
        _cache.clear()
