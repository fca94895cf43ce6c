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

Physical ranges: a number a user gives (an option, a field of an input file, `--param`) is a
physical quantity, and a finite but absurd value (a duration of 1e308 s, a resolution of 1e-320 m)
overflows or underflows deep inside a stage. The named quantities below (`DURATION`, `COORDINATE`,
`YAW`, ...) are the finite ranges that options (`legplan.cli.options.number`), file readers (`legplan.specio.FieldReader.number`'s
`allowed`) and parameter fields (`param`) share; a count field's range is finite too. `check_value`
is the one check, with the one error line "WHERE out of range: VALUE (allowed RANGE)"; it also
holds every finite float to `MAGNITUDE` (0, or between 1e-30 and 1e15 in magnitude), so a float
field declared up to "inf" takes no absurd value either.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

from legplan.errors import LegplanError

MAGNITUDE = (1e-30, 1e15)
"""Smallest and largest magnitude (besides 0) of any number read from text (`magnitude_problem`)."""

COORDINATE = "[-1e4, 1e4]"
"""m: a position on a map (x, y) or a height (10 km either way)."""
YAW = "[-12.6, 12.6]"
"""rad: a heading, up to two turns either way."""
VELOCITY = "[-20, 20]"
"""m/s: a planar velocity of a legged robot."""
DURATION = "[0.01, 3600]"
"""s: the duration of a motion (10 ms to an hour)."""
RATE = "(0, 10000]"
"""Hz: a sampling rate."""
WAIT = "[0, 600]"
"""s: a pause (settling, dwelling) of up to ten minutes."""
TIME_LIMIT = "(0, 86400]"
"""s: a wall-clock or simulated-time limit (up to a day)."""
RESOLUTION = "[1e-4, 100]"
"""m: the cell side of a map."""
LENGTH = "(0, 1000]"
"""m: a positive size (a radius, a height, a tolerance)."""
SENSING_RADIUS = "[0, 1000]"
"""m: how far a robot senses obstacles."""
CLEARANCE = "[0, 10]"
"""m: a clearance or margin."""
FRICTION = "(0, 10]"
"""a friction coefficient."""
FORCE = "(0, 1e6]"
"""N: a force bound of a legged robot's contact."""
TORQUE = "(0, 1e6]"
"""N·m: a joint torque bound."""
FRACTION = "[0, 1]"
"""a share of something."""
SCALE = "[-1e4, 1e4]"
"""a dimensionless factor (a height scale)."""
FACTOR = "(0, 100]"
"""a positive multiplier of a physical quantity (a simulated friction or mass scale)."""
WEIGHT = "[0, 1e9]"
"""a non-negative cost weight."""
COST = "(0, 1e12]"
"""a positive cost value or threshold."""
TOLERANCE = "[0, 1e9]"
"""an absolute or relative tolerance of a comparison."""

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


def magnitude_problem(value: float) -> str | None:
    """Why a finite number read from text is no physical quantity (outside `MAGNITUDE`), or None."""
    low, high = MAGNITUDE
    size = abs(value)
    if size > high:
        return f"is too large (magnitude above {high:g})"
    if 0 < size < low:
        return f"is too small (magnitude below {low:g}; use 0 for nothing)"
    return None


def check_value(value, allowed: str | Interval | tuple, where: str, params=None) -> None:
    """A `RangeError` "WHERE out of range: VALUE (allowed RANGE)" unless `value` lies in `allowed`
    (an interval, its text, or a tuple of values; named bounds read from `params`), and, for a
    finite float, within `MAGNITUDE` (an "inf" bound still means no absurd value). The one range
    check of options, file fields and parameter fields."""
    if isinstance(allowed, str):
        allowed = _parsed(allowed)
    if isinstance(value, float) and math.isfinite(value) and magnitude_problem(value):
        raise RangeError(f"{where} {magnitude_problem(value)}: {value!r}")
    inside = value in allowed if isinstance(allowed, tuple) else allowed.contains(value, params)
    if not inside:
        shown = ", ".join(map(repr, allowed)) if isinstance(allowed, tuple) else allowed.describe(params)
        raise RangeError(f"{where} out of range: {value!r} (allowed {shown})")


class RangeError(LegplanError):
    """A value outside its declared range (callers restate it for their file and field)."""


_PARSED: dict[str, Interval] = {}


def _parsed(text: str) -> Interval:
    if text not in _PARSED:
        _PARSED[text] = Interval.parse(text)
    return _PARSED[text]


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
        check_value(value, allowed, f"{what} parameter '{f.name}'", params)


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
