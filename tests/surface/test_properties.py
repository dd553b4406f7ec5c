"""Property-based probes of the surface (Hypothesis): any text for a numeric flag is
either accepted inside its range or refused by name with status 2; any value for a
Params field is either inside its declared Limit or refused naming the field."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simroad.cli import types as T
from simroad.cli.main import main
from simroad.errors import SimroadError
from simroad.noise import MODELS

_FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

_TEXT = st.one_of(
    st.text(max_size=12),
    st.integers(-(10**12), 10**12).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


@_FAST
@given(text=_TEXT)
def test_int_type_accepts_exactly_its_range(text):
    convert = T.int_in(1, 1000)
    try:
        value = convert(text)
    except argparse.ArgumentTypeError as exc:
        assert "expected an integer in [1, 1000]" in str(exc)
    else:
        assert isinstance(value, int) and 1 <= value <= 1000


@_FAST
@given(text=_TEXT)
def test_float_list_type_accepts_only_finite_numbers_in_range(text):
    convert = T.float_list(0.0, 1.0)
    try:
        values = convert(text)
    except argparse.ArgumentTypeError as exc:
        assert "expected" in str(exc)
    else:
        assert values and all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in values)


@_FAST
@given(seed=st.one_of(st.integers(-(10**6), -1), st.text(alphabet="abc-.", min_size=1, max_size=5)))
def test_any_bad_seed_exits_2_naming_the_flag(seed, capsys):
    code = main(["frames", "--out", "unused-never-created", "--seed", str(seed)])
    err = capsys.readouterr().err
    assert code == 2 and "--seed" in err and "Traceback" not in err


_FIELDS = [(cls, name, limit) for cls in (m.params_type for m in MODELS.values()) for name, limit in cls.LIMITS.items()]


@pytest.mark.parametrize(("cls", "name", "limit"), _FIELDS, ids=[f"{c.__name__}.{n}" for c, n, _ in _FIELDS])
@settings(max_examples=15, deadline=None)
@given(
    value=st.one_of(
        st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**9), 10**9), st.text(max_size=3), st.none()
    )
)
def test_params_field_is_in_its_limit_or_refused_by_name(cls, name, limit, value):
    if limit.length is not None:
        value = (value,) * limit.length
    try:
        params = cls(**{name: value})
    except SimroadError as exc:
        assert name in str(exc)
    else:
        got = getattr(params, name)
        items = got if isinstance(got, tuple) else (got,)
        for v in items:
            if v is None:
                assert limit.optional
            else:
                assert limit.low <= v <= limit.high
