"""Check every command-line value as argparse reads it: ``type=`` functions and a parser that records given flags.

Each factory returns a function for ``add_argument(type=...)`` that converts the text
or raises :class:`argparse.ArgumentTypeError`; argparse then prints
``simroad CMD: error: argument --FLAG: <what came, what is expected>`` and exits with
status 2, before any episode, frame or training runs. Library checks
(:mod:`simroad.core.validation`) are reused, so the command line and the Python API
refuse the same values with the same words.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from simroad.core.validation import check_choice, check_output_dir, check_output_file
from simroad.detector.registry import parse_detector_options, resolve_factory
from simroad.errors import InvalidParameterError, SimroadError
from simroad.filters import parse_filters
from simroad.noise import parse_noise

__all__ = [
    "MAX_SEED",
    "GivenParser",
    "checked",
    "choice",
    "choice_list",
    "filter_set",
    "filter_set_list",
    "finite_float",
    "float_in",
    "float_list",
    "given",
    "input_dir",
    "input_file",
    "int_in",
    "output_dir",
    "output_file",
    "seed",
    "text",
]

#: Largest seed gymnasium accepts for an environment (``reset(seed=...)``).
MAX_SEED = 2**31 - 1

_NAME_PREFIX = re.compile(r"^[A-Za-z_][A-Za-z0-9_\[\]' ]*: ")


def _typed(fn: Callable[[str], Any], name: str) -> Callable[[str], Any]:
    """Name ``fn`` for argparse's messages."""
    fn.__name__ = name  # argparse names the type in some messages
    return fn


def _strip_name(message: str) -> str:
    """A library message without its leading ``name: `` (argparse names the flag)."""
    return _NAME_PREFIX.sub("", message, count=1)


def checked(check: Callable[[str], Any], name: str = "value") -> Callable[[str], Any]:
    """Wrap a library check ``text -> value`` raising :class:`SimroadError`."""

    def convert(value: str) -> Any:
        try:
            return check(value)
        except SimroadError as exc:
            raise argparse.ArgumentTypeError(_strip_name(str(exc))) from None

    return _typed(convert, name)


def int_in(low: int, high: int) -> Callable[[str], int]:
    """An integer in ``[low, high]``."""

    def convert(value: str) -> int:
        try:
            number = int(value.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer in [{low}, {high}], got {value!r}.") from None
        if not low <= number <= high:
            raise argparse.ArgumentTypeError(f"expected an integer in [{low}, {high}], got {number}.")
        return number

    return _typed(convert, "integer")


def seed() -> Callable[[str], int]:
    """A seed: an integer in ``[0, 2**31 - 1]`` (gymnasium refuses negative seeds)."""
    return int_in(0, MAX_SEED)


def _float(value: str, what: str) -> float:
    try:
        number = float(value.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {value!r}.") from None
    if not math.isfinite(number):
        raise argparse.ArgumentTypeError(f"expected {what}, got {value!r} (not finite).")
    return number


def finite_float() -> Callable[[str], float]:
    """Any finite number."""
    return _typed(lambda value: _float(value, "a finite number"), "number")


def float_in(low: float, high: float, *, unit: str = "") -> Callable[[str], float]:
    """A number in ``[low, high]`` (``unit`` shown in the message)."""
    what = f"a number in [{low:g}, {high:g}]" + (f" {unit}" if unit else "")

    def convert(value: str) -> float:
        number = _float(value, what)
        if not low <= number <= high:
            raise argparse.ArgumentTypeError(f"expected {what}, got {number:g}.")
        return number

    return _typed(convert, "number")


def _split(value: str, example: str, what: str | None = None) -> list[str]:
    """The items of a comma-separated list, stripped; an empty list, an empty item
    (``a,,b``, ``a,``) or an item given twice is refused (a sweep or table would
    otherwise silently drop or repeat it). ``what``: the list's description in the
    empty list's message (default: a comma-separated list such as ``example``)."""
    items = [v.strip() for v in value.split(",")]
    if not any(items):
        what = what or f"a comma-separated list such as {example}"
        raise InvalidParameterError(f"value: expected {what}, got {value!r}.")
    if "" in items:
        raise InvalidParameterError(
            f"value: empty item in {value!r}: expected items separated by single commas, e.g. {example}."
        )
    _refuse_repeats(value, items)
    return items


def _refuse_repeats(value: str, items: Sequence[Any]) -> None:
    dup = [v for k, v in enumerate(items) if v in items[:k]]
    if dup:
        raise InvalidParameterError(
            f"value: {dup[0]!r} is listed more than once in {value!r}: expected each item once."
        )


def float_list(low: float, high: float) -> Callable[[str], tuple[float, ...]]:
    """Comma-separated numbers, each in ``[low, high]``, e.g. ``0.3,0.7``."""
    what = f"comma-separated numbers in [{low:g}, {high:g}] such as 0.3,0.7"

    def convert(value: str) -> tuple[float, ...]:
        try:
            items = _split(value, "0.3,0.7", what)
        except SimroadError as exc:
            raise argparse.ArgumentTypeError(_strip_name(str(exc))) from None
        out = []
        for item in items:
            try:
                number = float(item)
            except ValueError:
                raise argparse.ArgumentTypeError(f"{item!r} is not a number; expected {what}.") from None
            if not (math.isfinite(number) and low <= number <= high):
                raise argparse.ArgumentTypeError(f"{item!r} is out of range; expected {what}.")
            out.append(number)
        try:
            _refuse_repeats(value, out)  # 0.5,0.50 is one severity twice
        except SimroadError as exc:
            raise argparse.ArgumentTypeError(_strip_name(str(exc))) from None
        return tuple(out)

    return _typed(convert, "list")


def choice(valid: Sequence[str]) -> Callable[[str], str]:
    """One of ``valid`` (with a did-you-mean suggestion)."""
    return checked(lambda value: check_choice("value", value, valid), "choice")


def choice_list(valid: Sequence[str]) -> Callable[[str], tuple[str, ...]]:
    """Comma-separated names, each one of ``valid``."""

    def check(value: str) -> tuple[str, ...]:
        items = _split(value, ",".join(valid[:2]), f"comma-separated names from {', '.join(valid)}")
        return tuple(check_choice("value", v, valid) for v in items)

    return checked(check, "list")


def _each(value: str, check: Callable[[str], Any], example: str) -> str:
    for item in _split(value, example):
        check(item)
    return value


def weather() -> Callable[[str], str]:
    """A weather spec such as ``rain`` or ``rain+glare`` (returned as typed)."""

    return checked(lambda value: (parse_noise(value), value)[1], "noise")


def weather_list() -> Callable[[str], str]:
    """Comma-separated weather specs (returned as typed)."""

    return checked(lambda value: _each(value, parse_noise, "clear,rain+glare"), "list")


def filter_set() -> Callable[[str], str]:
    """A filter setting: ``none``, ``all`` or names joined by ``+`` (returned as typed)."""

    return checked(lambda value: (parse_filters(value), value)[1], "filters")


def filter_set_list() -> Callable[[str], str]:
    """Comma-separated filter settings (returned as typed)."""

    return checked(lambda value: _each(value, parse_filters, "none,all"), "list")


def text() -> Callable[[str], str]:
    """A non-empty string."""

    def convert(value: str) -> str:
        if not value.strip():
            raise argparse.ArgumentTypeError("expected a non-empty value, got ''.")
        return value

    return _typed(convert, "text")


def output_dir() -> Callable[[str], str]:
    """A directory that exists or can be created (nothing is created while parsing)."""

    def check(value: str) -> str:
        check_output_dir("out", value)
        return value

    return checked(check, "directory")


def output_file(suffixes: Callable[[], Iterable[str]] | None = None) -> Callable[[str], str]:
    """A file that can be written; ``suffixes()`` lists the accepted extensions."""

    def check(value: str) -> str:
        check_output_file("out", value, suffixes=None if suffixes is None else suffixes())
        return value

    return checked(check, "file")


def input_dir() -> Callable[[str], str]:
    """An existing directory."""

    def convert(value: str) -> str:
        p = Path(value)
        if not p.exists():
            raise argparse.ArgumentTypeError(f"{value!r} does not exist; expected an existing directory.")
        if not p.is_dir():
            raise argparse.ArgumentTypeError(f"{value!r} is not a directory; expected an existing directory.")
        return value

    return _typed(convert, "directory")


def input_file() -> Callable[[str], str]:
    """An existing, readable regular file."""

    def convert(value: str) -> str:
        p = Path(value)
        if not p.exists():
            raise argparse.ArgumentTypeError(f"{value!r} does not exist; expected an existing file.")
        if p.is_dir():
            raise argparse.ArgumentTypeError(f"{value!r} is a directory; expected a file.")
        if not os.access(p, os.R_OK):
            raise argparse.ArgumentTypeError(f"{value!r} is not readable.")
        return value

    return _typed(convert, "file")


class _Given:
    """Mixin of argparse actions: remember which destinations the user set."""

    def __call__(self, parser: Any, namespace: argparse.Namespace, values: Any, option_string: Any = None) -> None:
        super().__call__(parser, namespace, values, option_string)  # type: ignore[misc]
        given_set = getattr(namespace, "_given", None)
        if given_set is None:
            given_set = set()
            namespace._given = given_set
        given_set.add(self.dest)  # type: ignore[attr-defined]


class _Store(_Given, argparse._StoreAction):
    pass


class _StoreTrue(_Given, argparse._StoreTrueAction):
    pass


class _Append(_Given, argparse._AppendAction):
    pass


class GivenParser(argparse.ArgumentParser):
    """An ArgumentParser whose namespace records the options given on the command
    line (see :func:`given`), so a flag that does not apply can be refused."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.register("action", None, _Store)
        self.register("action", "store", _Store)
        self.register("action", "store_true", _StoreTrue)
        self.register("action", "append", _Append)


def given(args: argparse.Namespace) -> set[str]:
    """The destinations (``seed_start``, ...) set on the command line."""
    return set(getattr(args, "_given", set()))


def detector_spec() -> Callable[[str], str]:
    """A detector spec (see :mod:`simroad.detector.registry`), resolved now (returned as typed)."""

    def check(value: str) -> str:

        resolve_factory(value)
        return value.strip()

    return checked(check, "detector")


def detector_specs() -> Callable[[str], str]:
    """Comma-separated detector specs, each resolved now (returned as typed)."""

    return checked(lambda value: _each(value, resolve_factory, "paper,mine.py:Detector"), "detectors")


def detector_option(*, targeted: bool = False) -> Callable[[str], str]:
    """``key=value`` (``SPEC@key=value`` where ``targeted``), the key an identifier
    (returned as typed; the value is read by the registry)."""

    def check(value: str) -> str:

        pair = value.rpartition("@")[2] if targeted else value
        parse_detector_options([pair])
        return value

    return checked(check, "detector option")
