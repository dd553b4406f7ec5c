"""Check an episode record against ``--require`` gates such as ``'offroad_fraction<=0.01'``."""

from __future__ import annotations

import operator
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from simroad.core.validation import check_choice
from simroad.errors import InvalidParameterError
from simroad.experiments.results import ROW_TYPES

__all__ = ["TEXT_KEYS", "Requirement", "check_requirements", "parse_requirement"]

#: Record keys that hold text (names, versions, specs): no number compares with them.
TEXT_KEYS = frozenset(k for k, kind in ROW_TYPES.items() if kind in ("text", "label", "text|null"))

_OPS = {"<=": operator.le, ">=": operator.ge, "<": operator.lt, ">": operator.gt}
_PATTERN = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(<=|>=|<|>)\s*([-+0-9.eE]+|true|false)\s*$")


@dataclass(frozen=True)
class Requirement:
    """``key op value``, e.g. ``fnr <= 0.05``."""

    key: str
    op: str
    value: float

    def holds(self, actual: Any) -> bool:
        """Whether the record's value ``actual`` meets the gate (None counts as +inf)."""
        if actual is None:  # e.g. min_ttc_s when nothing ever closed in: infinitely safe
            actual = float("inf")
        return bool(_OPS[self.op](float(actual), self.value))

    def __str__(self) -> str:
        return f"{self.key}{self.op}{self.value:g}"


def parse_requirement(text: str, *, valid_keys: Sequence[str]) -> Requirement:
    """Parse ``'key<=value'`` (operators ``<``, ``<=``, ``>``, ``>=``)."""
    m = _PATTERN.match(text)
    if not m:
        raise InvalidParameterError(
            f"require: cannot parse {text!r}; expected KEY OP VALUE with OP one of <, <=, >, >= "
            f"(for example 'offroad_fraction<=0.01')."
        )
    key, op, raw = m.groups()
    check_choice("require", key, valid_keys)
    if key in TEXT_KEYS:
        raise InvalidParameterError(
            f"require: {key!r} is a text field of the record, not a number, so {text!r} cannot be checked; "
            "gate on a numeric key such as 'fnr<=0.05' or 'offroad_fraction<=0.01'."
        )
    value = {"true": 1.0, "false": 0.0}.get(raw)
    if value is None:
        try:
            value = float(raw)
        except ValueError:
            raise InvalidParameterError(f"require: {raw!r} in {text!r} is not a number.") from None
    return Requirement(key, op, value)


def check_requirements(record: Mapping[str, Any], requirements: Sequence[Requirement]) -> list[str]:
    """Messages for the violated requirements (empty when all hold)."""
    out = []
    for req in requirements:
        actual = record.get(req.key)
        if not req.holds(actual):
            out.append(f"requirement {req} violated: {req.key} = {actual}")
    return out
