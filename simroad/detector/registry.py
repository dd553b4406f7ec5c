"""Any road detector in the same closed loop: the protocol, finding one by name, the filters in front.

**The protocol.** A detector is any object with

``predict(image: uint8 (H, W, 3) RGB) -> bool (H, W)``
    True where it sees road;

and optionally ``reset()`` (called at the start of every episode, for detectors with
a memory of past frames), ``set_camera(camera)`` (called once per episode with the
calibrated :class:`~simroad.camera.PinholeCamera` the frames come from: its
intrinsics, mounting, ``horizon_row``, ``ground_valid`` and ground map, for a detector
that uses where road can be) and the attributes ``name`` and ``version`` (strings, for
the records).

**Episodes.** A detector may instead keep what persists across an episode's frames out
of itself: its optional ``episode(camera)`` returns an object of the same protocol that
predicts one episode's frames in order (then neither ``reset`` nor ``set_camera`` is
called). :func:`start_episode` starts one either way; the mask driver calls it at every
episode and owns what it returns. The shipped :class:`~simroad.detector.RoadDetector`,
the built-in ``paper`` detector, works so: its ``predict`` leaves it unchanged, and
:meth:`~simroad.detector.RoadDetector.episode` carries the camera's ground mask and
the glare memory (:mod:`simroad.detector.episode`).

**Finding one by name** (:func:`load_detector`), a *spec* is one of

- a registered name: ``paper``, anything :func:`register` added, or an entry point of
  the group ``simroad.detectors`` of an installed package (``[project.entry-points.
  "simroad.detectors"] mine = "my_pkg.detect:MyDetector"``), the way gymnasium
  environments and pytest plugins register;
- ``package.module:attr``, an importable class or factory;
- ``path/to/file.py:attr``, a class or factory in a Python file.

The class or factory is called with keyword options (from TOML or
``--detector-option key=value``). A detector is imported and built once per process
and spec+options (:func:`load_detector` caches it), not once per episode.

**The paper's filters in front of any detector.** :class:`FilteredDetector` runs the
shadow, rain/snow and light filters (:func:`simroad.filters.apply_filters`) on the
frame before the detector sees it: "does the shadow filter help *my* model?" is the
paper's ablation, generalised. The ``paper`` detector runs its filters itself (its
fast lookup-table path), with the same result.
"""

from __future__ import annotations

import ast
import functools
import importlib
import importlib.metadata
import importlib.util
import inspect
import sys
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from simroad import __version__
from simroad.detector.detector import RoadDetector
from simroad.errors import DetectorFailedError, InvalidParameterError, SimroadError
from simroad.filters import apply_filters, format_filters
from simroad.filters.pipeline import check_filters, check_variant

__all__ = [
    "ENTRY_POINT_GROUP",
    "Detector",
    "FilteredDetector",
    "available_detectors",
    "check_detector",
    "check_prediction",
    "clear_detector_cache",
    "describe",
    "load_detector",
    "parse_detector_options",
    "predict_alone",
    "predict_checked",
    "register",
    "resolve_factory",
    "start_episode",
]

#: The entry-point group an installed package registers its detectors in.
ENTRY_POINT_GROUP = "simroad.detectors"


@runtime_checkable
class Detector(Protocol):
    """What simroad needs of a road detector (``reset``, ``set_camera``, ``episode``,
    ``name``, ``version`` optional)."""

    def predict(self, image: np.ndarray) -> np.ndarray:  # pragma: no cover - protocol
        """Road mask, bool (H, W), of an RGB uint8 (H, W, 3) frame."""
        ...


def _paper(*, filters: Sequence[str] = (), filter_variant: str = "improved", morphology: bool = True) -> Any:
    """The shipped model of the paper's detector (:meth:`RoadDetector.pretrained`)."""

    det = RoadDetector.pretrained(filters=filters, morphology=morphology, filter_variant=filter_variant)
    det.name, det.version = "paper", f"simroad {__version__}"
    return det


_REGISTRY: dict[str, Callable[..., Any]] = {"paper": _paper}


def register(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` (a class or a callable taking keyword options) under ``name``."""
    if not isinstance(name, str) or not name.isidentifier():
        raise InvalidParameterError(f"name: expected a detector name like 'my_detector' (an identifier), got {name!r}.")
    if not callable(factory):
        raise InvalidParameterError(f"factory: expected a class or a callable returning a detector, got {factory!r}.")
    _REGISTRY[name] = factory
    clear_detector_cache()


def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}


def available_detectors() -> dict[str, str]:
    """Every detector known by name: ``{name: where it comes from}`` (built in,
    :func:`register`, or the entry point's ``module:attr``)."""
    out = {name: ("built in" if name == "paper" else "registered") for name in _REGISTRY}
    for name, ep in _entry_points().items():
        out.setdefault(name, f"entry point {ep.value}")
    return out


def _how_to() -> str:
    names = ", ".join(sorted(available_detectors()))
    return (
        f"use a registered name ({names}), 'package.module:attr' or 'path/to/file.py:attr' "
        f"(a class or factory returning an object with predict(image) -> bool mask)"
    )


def resolve_factory(spec: str) -> Callable[..., Any]:
    """The class or factory a detector spec names (see the module docstring)."""
    if not isinstance(spec, str) or not spec.strip():
        raise InvalidParameterError(f"detector: expected a detector spec, got {spec!r}; {_how_to()}.")
    spec = spec.strip()
    if spec in _REGISTRY:
        return _REGISTRY[spec]
    if ":" not in spec:
        eps = _entry_points()
        if spec in eps:
            try:
                return eps[spec].load()
            except Exception as exc:  # a broken plug-in is reported by name
                raise InvalidParameterError(
                    f"detector: the entry point {spec!r} ({eps[spec].value}) failed to load: "
                    f"{type(exc).__name__}: {exc}."
                ) from None
        raise InvalidParameterError(f"detector: unknown detector {spec!r}; {_how_to()}.")
    where, _, attr = spec.rpartition(":")
    if not attr.isidentifier():
        raise InvalidParameterError(f"detector: {spec!r} names no attribute after ':'; {_how_to()}.")
    if where.endswith(".py") or "/" in where or "\\" in where:
        module = _module_from_file(spec, Path(where))
    else:
        if not all(part.isidentifier() for part in where.split(".")):
            raise InvalidParameterError(
                f"detector: {spec!r} names no importable module before ':' (got {where!r}); {_how_to()}."
            )
        try:
            module = importlib.import_module(where)
        except ImportError as exc:
            raise InvalidParameterError(
                f"detector: cannot import {where!r} for {spec!r} ({exc}); install the package or put it on PYTHONPATH."
            ) from None
        except Exception as exc:  # the module itself failed while importing: report it by name
            raise InvalidParameterError(
                f"detector: importing {where!r} for {spec!r} failed: {type(exc).__name__}: {exc}."
            ) from exc
    try:
        factory = getattr(module, attr)
    except AttributeError:
        raise InvalidParameterError(f"detector: {where!r} has no attribute {attr!r} (spec {spec!r}).") from None
    if not callable(factory):
        raise InvalidParameterError(f"detector: {spec!r} is a {type(factory).__name__}, not a class or factory.")
    return factory


def _module_from_file(spec: str, path: Path) -> Any:
    path = path.expanduser().resolve()
    if not path.is_file():
        raise InvalidParameterError(f"detector: no file {str(path)!r} (spec {spec!r}).")
    name = f"simroad_user_detector_{abs(hash(str(path)))}"
    if name in sys.modules:
        return sys.modules[name]
    loader_spec = importlib.util.spec_from_file_location(name, path)
    if loader_spec is None or loader_spec.loader is None:
        raise InvalidParameterError(f"detector: {str(path)!r} is not a Python file (spec {spec!r}).")
    module = importlib.util.module_from_spec(loader_spec)
    sys.modules[name] = module
    try:
        loader_spec.loader.exec_module(module)
    except Exception as exc:  # the user's file: report it by name
        del sys.modules[name]
        raise InvalidParameterError(f"detector: running {str(path)!r} failed: {type(exc).__name__}: {exc}.") from None
    return module


def check_detector(spec: str, options: Any = None) -> tuple[Callable[..., Any], dict[str, Any]]:
    """Resolve ``spec`` and check ``options`` against its class or factory's signature
    now (before any episode): the factory and the parsed options, or an error naming
    ``detector`` or ``detector_options``."""
    factory = resolve_factory(spec)
    opts = parse_detector_options(options)
    if factory is _paper and ({"filters", "filter_variant"} & set(opts)):
        raise InvalidParameterError(
            "detector_options: the paper detector's filters are the spec's filters (filters=, --filters), "
            f"not an option; got {sorted(opts)}."
        )
    try:  # bind, not bind_partial: the factory is called with these options alone
        inspect.signature(factory).bind(**opts)
    except TypeError as exc:
        raise InvalidParameterError(
            f"detector_options: {spec!r} did not accept {sorted(opts)} ({exc}); its signature: {_signature(factory)}."
        ) from None
    except ValueError:  # no signature to check (a builtin): checked when it is built
        pass
    return factory, opts


def parse_detector_options(items: Iterable[str] | Mapping[str, Any] | None) -> dict[str, Any]:
    """Options for a detector's factory: a mapping (from TOML) as it is, or
    ``key=value`` strings (from ``--detector-option``), the value read as a Python
    literal (``3``, ``0.5``, ``True``, ``'x'``, ``[1, 2]``) or else as a string."""
    if items is None:
        return {}
    if isinstance(items, str) or not isinstance(items, Mapping | list | tuple):
        raise InvalidParameterError(
            f"detector_options: expected a mapping of keyword options such as {{'threshold': 0.5}} "
            f"(or key=value strings), got {type(items).__name__} {items!r}."
        )
    if isinstance(items, Mapping):
        for key in items:
            if not isinstance(key, str) or not key.isidentifier():
                raise InvalidParameterError(f"detector options: expected keyword names, got {key!r}.")
        return dict(items)
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = str(item).partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise InvalidParameterError(f"--detector-option: expected key=value (e.g. threshold=0.5), got {item!r}.")
        try:
            value: Any = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError):
            value = text.strip()
        out[key] = value
    return out


def _freeze(value: Any) -> Any:
    if isinstance(value, Mapping):
        return tuple(sorted((k, _freeze(v)) for k, v in value.items()))
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    return value


def load_detector(
    spec: str,
    options: Mapping[str, Any] | None = None,
    *,
    filters: Sequence[str] = (),
    filter_variant: str = "improved",
) -> Any:
    """Build the detector ``spec`` names with keyword ``options``, the paper's
    ``filters`` in front (see the module docstring). Cached per process: the same
    spec, options and filters give the same object (start each episode with
    :func:`start_episode`)."""
    opts = parse_detector_options(options)
    names = check_filters(filters)
    variant = check_variant(filter_variant)
    return _load(spec, _freeze(opts), names, variant)


@functools.lru_cache(maxsize=32)
def _load(spec: str, frozen: tuple, filters: tuple[str, ...], variant: str) -> Any:
    factory, opts = check_detector(spec, {k: _thaw(v) for k, v in frozen})
    if factory is _paper:
        return _paper(filters=filters, filter_variant=variant, **opts)
    try:
        detector = factory(**opts)
    except SimroadError:
        raise
    except Exception as exc:  # the user's class or factory: report it by name (the cause stays chained)
        raise InvalidParameterError(
            f"detector: building {spec!r} with options {opts!r} failed: {type(exc).__name__}: {exc}."
        ) from exc
    if not callable(getattr(detector, "predict", None)):
        raise InvalidParameterError(
            f"detector: {spec!r} built a {type(detector).__name__} without a predict(image) method; "
            "a detector needs predict(uint8 (H, W, 3)) -> bool (H, W)."
        )
    if getattr(detector, "name", None) is None:
        try:
            detector.name = spec
        except AttributeError:
            pass
    return FilteredDetector(detector, filters, filter_variant=variant) if filters else detector


def clear_detector_cache() -> None:
    """Forget the detectors :func:`load_detector` built (they are built anew on request)."""
    _load.cache_clear()


def _thaw(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _signature(factory: Callable[..., Any]) -> str:
    try:
        return f"{getattr(factory, '__name__', 'factory')}{inspect.signature(factory)}"
    except (TypeError, ValueError):
        return "unknown"


class FilteredDetector:
    """``detector`` behind the paper's filters: each frame goes through
    :func:`simroad.filters.apply_filters` (``filters``, ``filter_variant``) first."""

    def __init__(self, detector: Any, filters: Sequence[str], *, filter_variant: str = "improved") -> None:
        if not callable(getattr(detector, "predict", None)):
            raise InvalidParameterError(
                f"detector: expected an object with predict(image), got {type(detector).__name__}."
            )
        self.detector = detector
        self.filters = check_filters(filters)
        self.filter_variant = check_variant(filter_variant)

    @property
    def name(self) -> str:
        return describe(self.detector)["name"]

    @property
    def version(self) -> str:
        return describe(self.detector)["version"]

    def episode(self, camera: Any = None) -> FilteredDetector:
        """Start an episode of the wrapped detector (:func:`start_episode`), behind the same filters."""
        return FilteredDetector(start_episode(self.detector, camera), self.filters, filter_variant=self.filter_variant)

    def predict(self, image: np.ndarray) -> np.ndarray:
        return self.detector.predict(apply_filters(image, self.filters, variant=self.filter_variant))

    def __repr__(self) -> str:
        return f"FilteredDetector({self.detector!r}, filters={format_filters(self.filters)!r})"


def describe(detector: Any) -> dict[str, str]:
    """``{"name", "version"}`` of a detector for the records: its ``name`` and
    ``version`` attributes, else its class name and ``""``."""
    name = getattr(detector, "name", None)
    version = getattr(detector, "version", None)
    return {
        "name": str(name) if name is not None else type(detector).__name__,
        "version": str(version) if version is not None else "",
    }


def start_episode(detector: Any, camera: Any = None) -> Any:
    """The object that predicts one episode's frames in order, from ``detector``'s start.

    The detector's ``episode(camera)`` where it has one (the shipped
    :class:`~simroad.detector.RoadDetector`: :meth:`~simroad.detector.RoadDetector.episode`);
    else the detector itself, after its ``reset()`` and, given a ``camera``, its
    ``set_camera(camera)``, where it has them. Either has ``predict(image)``; the caller
    owns it for the episode (the mask driver starts one per episode).

    Parameters
    ----------
    detector : object with ``predict(uint8 (H, W, 3)) -> bool (H, W)``
        Any detector of the protocol (see the module docstring).
    camera : PinholeCamera or None, optional
        The calibrated camera the episode's frames come from; None for frames without
        one (``set_camera`` is then not called).
    """
    episode = getattr(detector, "episode", None)
    if callable(episode):
        return episode(camera)
    reset = getattr(detector, "reset", None)
    if callable(reset):
        reset()
    set_camera = getattr(detector, "set_camera", None)
    if camera is not None and callable(set_camera):
        set_camera(camera)
    return detector


def predict_alone(detector: Any, image: np.ndarray) -> np.ndarray:
    """The detector's bool (H, W) mask of one frame on its own: the first frame of a new
    episode without a camera (:func:`start_episode`), as when frames from different
    episodes are scored one at a time."""
    return predict_checked(start_episode(detector), image, detector)


def predict_checked(episode: Any, image: np.ndarray, detector: Any) -> np.ndarray:
    """``episode.predict(image)`` as a bool (H, W) mask (:func:`check_prediction`); an
    exception the detector raises becomes a :class:`~simroad.errors.DetectorFailedError`
    that names the detector and where it raised (the original chained)."""
    try:
        out = episode.predict(image)
    except SimroadError:  # simroad's own message already says what to fix
        raise
    except Exception as exc:
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else ""
        raise DetectorFailedError(
            f"detector {describe(detector)['name']!r}: predict() raised {type(exc).__name__}: {exc}{where}."
        ) from exc
    return check_prediction(out, image.shape[:2], detector)


def check_prediction(mask: Any, shape: tuple[int, int], detector: Any) -> np.ndarray:
    """A detector's output as a bool (H, W) mask, or a
    :class:`~simroad.errors.DetectorFailedError` naming the detector."""
    arr = np.asarray(mask)
    if arr.shape != tuple(shape):
        raise DetectorFailedError(
            f"detector {describe(detector)['name']!r}: predict() returned shape {arr.shape}, expected the "
            f"frame's {tuple(shape)} (a bool road mask)."
        )
    if arr.dtype != np.bool_:
        if arr.dtype.kind not in "biu":
            raise DetectorFailedError(
                f"detector {describe(detector)['name']!r}: predict() returned {arr.dtype}, expected a bool mask "
                "(threshold scores yourself, e.g. scores > 0.5)."
            )
        arr = arr != 0
    return arr
