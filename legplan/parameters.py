"""Parameter declarations: each field of a parameter dataclass declared once with its default, its
allowed range, its paper symbol and its doc (`param`), and the one range check (`check_ranges`) with
the one error line "WHAT parameter 'NAME' out of range: VALUE (allowed RANGE)"; `Parameters`,
the base of the parameter dataclasses, runs it after construction.

    @dataclass(frozen=True)
    class StepPlanParams(Parameters):
        what = "step planner"  # the error line's WHAT (not a field: no annotation)
        epsilon: float = param(1e-3, "(0, inf)", "ε", "m: allowed stance-foot deviation per foot")

A range is an interval in the usual notation, "[0, inf)", "(0, 1]", whose bounds are numbers or
the names of other attributes of the same object ("[min_poses, inf)"), or a tuple of the allowed
values ("velocity", "target"). A None value is not checked (a default filled in later, e.g. from
the robot's size). `inherit` declares a field as another class's field (same default, range, doc).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

from legplan.errors import LegplanError

_INTERVAL = re.compile(r"\s*([\[(])\s*([^,\s]+)\s*,\s*([^,\s]+)\s*([\])])\s*")


@dataclass(frozen=True)
class Interval:
    """Allowed values between two bounds, each a number or the name of another attribute."""

    low: float | str
    high: float | str
    low_open: bool
    high_open: bool

    @classmethod
    def parse(cls, text: str) -> Interval:
        """"(0, inf)", "[0, dt_ref)", ...; a `ValueError` for anything else."""
        match = _INTERVAL.fullmatch(text)
        if match is None:
            raise ValueError(f"not an interval: {text!r}")
        opening, low, high, closing = match.groups()
        return cls(_bound(low), _bound(high), opening == "(", closing == ")")

    def contains(self, value, params) -> bool:
        """Whether `value` lies inside, with named bounds read from `params` (a None bound: no limit)."""
        low, high = (getattr(params, b) if isinstance(b, str) else b for b in (self.low, self.high))
        above = low is None or (value > low if self.low_open else value >= low)
        below = high is None or (value < high if self.high_open else value <= high)
        return above and below

    def describe(self, params=None) -> str:
        """The interval as written, a named bound followed by its value in `params` if given."""
        low, high = (_describe_bound(b, params) for b in (self.low, self.high))
        return f"{'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"


def _describe_bound(bound: float | str, params) -> str:
    if not isinstance(bound, str):
        return f"{bound:g}"
    return bound if params is None else f"{bound} = {getattr(params, bound):g}"


def _bound(token: str) -> float | str:
    """A number ("inf", "1e-3") or an attribute name."""
    try:
        return float(token)
    except ValueError:
        if not token.isidentifier():
            raise ValueError(f"interval bound {token!r} is neither a number nor a name") from None
        return token


def param(default, range: str | tuple | None = None, symbol: str | None = None, doc: str = ""):
    """A dataclass field with `default` and, as metadata, its allowed `range` (an interval string
    or a tuple of allowed values), paper `symbol` and `doc`."""
    allowed = Interval.parse(range) if isinstance(range, str) else range
    return dataclasses.field(default=default, metadata={"range": allowed, "symbol": symbol, "doc": doc})


def inherit(cls, name: str, **changes):
    """The field `name` of the parameter dataclass `cls` declared again (same default and metadata;
    `changes` replace entries: range, symbol, doc), for a class that must hold the same setting."""
    source = next(f for f in dataclasses.fields(cls) if f.name == name)
    meta = dict(source.metadata)
    if isinstance(changes.get("range"), str):
        changes["range"] = Interval.parse(changes["range"])
    meta.update(changes)
    return dataclasses.field(default=source.default, metadata=meta)


def check_ranges(params, what: str) -> None:
    """Raise `LegplanError` "WHAT parameter 'NAME' out of range: VALUE (allowed RANGE)" for the first
    field of `params` (in declaration order) whose value lies outside its declared range."""
    for f in dataclasses.fields(params):
        allowed, value = f.metadata.get("range"), getattr(params, f.name)
        if allowed is None or value is None:
            continue
        inside = value in allowed if isinstance(allowed, tuple) else allowed.contains(value, params)
        if not inside:
            shown = ", ".join(map(repr, allowed)) if isinstance(allowed, tuple) else allowed.describe(params)
            raise LegplanError(f"{what} parameter '{f.name}' out of range: {value!r} (allowed {shown})")


class Parameters:
    """Base of a parameter dataclass: its fields' ranges checked on construction (`check_ranges`
    with the class attribute `what`), `as_dict` and `replace`."""

    what = "legplan"

    def __post_init__(self):
        check_ranges(self, self.what)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def replace(self, **changes):
        """A copy with `changes`, checked again."""
        return dataclasses.replace(self, **changes)
