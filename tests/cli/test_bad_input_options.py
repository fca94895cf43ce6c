"""Bad numbers on the command line (issue 18 classes 1-4), for every numeric option of every command,
enumerated from the click tree: NaN, ±inf, an overflowing literal, text, and values outside the
option's range are refused at parse time (exit 2, one line naming the option, no output)."""

from __future__ import annotations

import math

import click
import pytest
from bad_input_support import (FLOAT_OPTIONS, INT_OPTIONS, assert_refused, command_line, count_of, element_types,
                               few, invoke, option_ids, valid_value)
from hypothesis import given
from hypothesis import strategies as st

from legplan.cli.options import FiniteFloat, Numbers


def _bad_floats(kind) -> list[str]:
    bad = ["nan", "inf", "-inf", "1e999", "-1e999", "abc"]
    if getattr(kind, "min", None) is not None:
        bad += [str(kind.min - 1)] + ([str(kind.min)] if kind.min_open else [])
    if getattr(kind, "max", None) is not None:
        bad += [str(kind.max + 1)] + ([str(kind.max)] if kind.max_open else [])
    return bad


def test_every_float_option_is_a_finite_type_and_every_int_option_bounded():
    assert len(FLOAT_OPTIONS) >= 20  # the enumeration itself found the numeric options
    for path, _, param in FLOAT_OPTIONS:
        for kind in element_types(param):
            assert isinstance(kind, (FiniteFloat, Numbers)), f"{' '.join(path)} {param.opts[-1]}: {kind!r}"
    for path, _, param in INT_OPTIONS:
        kind = param.type
        assert isinstance(kind, click.IntRange) and kind.min is not None, f"{' '.join(path)} {param.opts[-1]}"


@pytest.mark.parametrize("path, command, param", FLOAT_OPTIONS, ids=option_ids(FLOAT_OPTIONS))
def test_bad_float_option_values_are_refused(tmp_path, path, command, param):
    out = tmp_path / "placeholder.h5"
    count = count_of(param)
    for position in range(count):
        kind = element_types(param)[min(position, len(element_types(param)) - 1)]
        for bad in _bad_floats(kind):
            values = [valid_value(kind)] * count
            values[position] = bad
            result = invoke(command_line(path, command, param, values, tmp_path))
            assert_refused(result, f"'{param.opts[-1]}'", output=out)


@pytest.mark.parametrize("path, command, param", INT_OPTIONS, ids=option_ids(INT_OPTIONS))
def test_bad_int_option_values_are_refused(tmp_path, path, command, param):
    out = tmp_path / "placeholder.h5"
    for bad in ["nan", "inf", "1.5", "abc", "", str(param.type.min - 1)]:
        result = invoke(command_line(path, command, param, [bad], tmp_path))
        assert_refused(result, f"'{param.opts[-1]}'", output=out)


KINDS = sorted({(k.min, k.max, k.min_open, k.max_open) for _, _, p in FLOAT_OPTIONS
                for k in element_types(p) if isinstance(k, FiniteFloat)}, key=str)


@few(30)
@given(bounds=st.sampled_from(KINDS), value=st.floats(allow_nan=True, allow_infinity=True))
def test_finite_float_accepts_exactly_the_finite_values_in_range(bounds, value):
    low, high, low_open, high_open = bounds
    kind = FiniteFloat(min=low, max=high, min_open=low_open, max_open=high_open)
    inside = math.isfinite(value) and (
        low is None or value > low or (value == low and not low_open)) and (
        high is None or value < high or (value == high and not high_open))
    try:
        converted = kind.convert(repr(value), None, None)
    except click.BadParameter:
        assert not inside
    else:
        assert inside and converted == value


@few(25)
@given(case=st.sampled_from(FLOAT_OPTIONS),
       bad=st.one_of(st.sampled_from(["nan", "-nan", "NaN", "inf", "+inf", "-Infinity", "1e309"]),
                     st.floats(min_value=1e308, allow_infinity=False).map(lambda v: f"{v!r}0")))
def test_any_non_finite_spelling_is_refused_by_any_float_option(tmp_path_factory, case, bad):
    path, command, param = case
    tmp_path = tmp_path_factory.mktemp("opt")
    values = [valid_value(element_types(param)[0])] * count_of(param)
    values[-1] = bad
    result = invoke(command_line(path, command, param, values, tmp_path))
    assert_refused(result, f"'{param.opts[-1]}'", output=tmp_path / "placeholder.h5")
