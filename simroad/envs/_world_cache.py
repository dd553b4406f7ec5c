"""The last worlds built in this process, reused by a reset that would build them again.

A :class:`~simroad.camera.world.WorldRaster` (its lane outlines and ground textures)
and its :class:`~simroad.camera.scenery.Scenery` are pure functions of the road
network's geometry, the world generator's state, the texel size, the palette, the
extra markings and the scenery's options; building them, and rendering the first
frame's tiles and scenery cells, is most of a reset. gymnasium's ``check_env`` resets
twice with one seed, a paired sweep runs several filter sets on one world, the tests
reset the same worlds again and again.

The cache keeps the last :data:`WORLDS` worlds as masters (the first frame's tiles of
the last :data:`TILED` only, to bound the memory) and hands out shallow copies:
a copy shares the master's textures, lane outlines and road index, and starts its own
tile and cell caches from the ones the master's first episode filled for its first
frame (:func:`remember`; every tile and cell is a pure function of its index), so
nothing an episode renders later is kept, and two live episodes share no mutable
state. A copy has windows of its own (a window's origin depends on the poses it was
asked for, and enters the camera's warp). A hit sets the world generator to the state
the build left it in, so every later draw is the one a fresh build would give.

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
from simroad.camera.mesh import Mesh
from simroad.camera.palette import Palette
from simroad.camera.scenery import Scenery

__all__ = ["TILED", "WORLDS", "clear", "remember", "scenery", "world"]

#: Worlds kept: each holds its textures and the first frame's scenery cells (~5 MB) ...
WORLDS = 8
#: ... and the most recent of them the first frame's tiles too (~25 MB at the default camera).
TILED = 2
_SCENERIES = 2  # sceneries kept per world
_DEPTH = 4  # nesting of a lane's attributes looked into


class _Uncacheable(Exception):
    """A value the key cannot describe exactly."""


@dataclass
class _Entry:
    world: WorldRaster  # the master, never handed out; its tile caches hold the first frame's
    rng_state: Mapping[str, Any]  # the world generator's state after the build
    remembered: bool = False  # the first frame's tiles are in the master
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


def _trim() -> None:
    """Keep :data:`WORLDS` worlds, the first frame's tiles of the last :data:`TILED` (under the lock)."""
    while len(_cache) > WORLDS:
        _cache.popitem(last=False)
    for old in list(_cache.values())[: max(len(_cache) - TILED, 0)]:
        old.world._tiles, old.world._tile_levels, old.remembered = OrderedDict(), OrderedDict(), False


def _view(master: WorldRaster) -> WorldRaster:
    """A copy of ``master`` sharing its immutable parts, with tile caches started from
    the master's, windows of its own and no scenery."""
    out = copy.copy(master)
    out._tiles = OrderedDict(master._tiles)
    out._tile_levels = OrderedDict(master._tile_levels)
    out._windows = {}
    out.scenery = None
    return out


def _scenery_view(master: Scenery) -> Scenery:
    """A copy of ``master`` sharing its road index, with cell caches started from the master's."""
    out = copy.copy(master)
    out._cells = OrderedDict(master._cells)
    out._cands = OrderedDict(master._cands)
    out._last = (None, Mesh.empty())
    return out


def _entry_of(world: WorldRaster) -> _Entry | None:
    with _lock:
        return next((e for e in _cache.values() if e.world.shapes is world.shapes), None)


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
            _trim()
    if entry is None:
        master = WorldRaster(network, rng, texel_m=texel_m, palette=palette, extra_markings=extra_markings)
        entry = _Entry(master, copy.deepcopy(rng.bit_generator.state))
        with _lock:
            _cache[key] = entry
            _trim()
    else:
        rng.bit_generator.state = dict(copy.deepcopy(entry.rng_state))
    return _view(entry.world)


def scenery(world: WorldRaster, seed: int, **options: Any) -> Scenery:
    """``Scenery(world.shapes, seed, **options)``, reused when this cached world built
    it before (the objects of a cell are a pure function of these): a shallow copy
    sharing the master's road index, with cell caches of its own started from the
    master's, which the episode's references alone keep alive."""
    entry = _entry_of(world)
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
            return _scenery_view(found)
    built = Scenery(world.shapes, seed, **options)
    with _lock:
        entry.sceneries[key] = built
        while len(entry.sceneries) > _SCENERIES:
            entry.sceneries.popitem(last=False)
    return _scenery_view(built)


def remember(world: WorldRaster) -> None:
    """Keep in ``world``'s masters (when cached) the tiles and scenery cells its caches
    hold now, once: called after a reset's first frame, they are what the next reset of
    the same world renders first."""
    entry = _entry_of(world)
    if entry is None:
        return
    with _lock:
        if not entry.remembered:
            entry.world._tiles = OrderedDict(world._tiles)
            entry.world._tile_levels = OrderedDict(world._tile_levels)
            entry.remembered = True
        scenery = world.scenery
        if isinstance(scenery, Scenery):
            master = next((m for m in entry.sceneries.values() if m.road is scenery.road), None)
            if master is not None and not master._cands:  # a master renders nothing itself
                master._cells = OrderedDict(scenery._cells)
                master._cands = OrderedDict(scenery._cands)


def clear() -> None:
    """Forget every cached world."""
    with _lock:
        _cache.clear()
