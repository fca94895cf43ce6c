"""One parameter mechanism: fields declared with `param` (default, range, symbol, doc), one
`check_ranges` with one error line, `inherit` for a class that holds another's setting."""

import dataclasses
import math
from dataclasses import dataclass

import pytest

from legplan.baselines.nav import NavBaselineParams
from legplan.baselines.step import StepBaselineParams
from legplan.dyn.costs import CostWeights
from legplan.dyn.settings import DynParams
from legplan.errors import LegplanError
from legplan.nav.params import NavParams
from legplan.nav.simulate.mission import NavRunParams
from legplan.nav.teb.params import TebParams
from legplan.parameters import Interval, Parameters, inherit, param
from legplan.sim.run import SimParams
from legplan.dyn.replan import ReplanParams
from legplan.solve.auglag import ALParams
from legplan.solve.hinged import HingedParams
from legplan.stepplan.params import StepPlanParams
from legplan.stepseq.generate import GenerateParams

PARAMETER_CLASSES = [GenerateParams, StepPlanParams, StepBaselineParams, NavParams, NavBaselineParams,
                     TebParams, NavRunParams, DynParams, CostWeights, ALParams, HingedParams, SimParams, ReplanParams]


@dataclass(frozen=True)
class _Example(Parameters):
    what = "example"

    low: float = param(1.0, "[0, inf)", "ℓ", "a length")
    high: float = param(2.0, "(low, 10]")
    maybe: float | None = param(None, "(0, 1)")
    mode: str = param("a", ("a", "b"))


@pytest.mark.parametrize("text, inside, outside", [
    ("[0, inf)", [0.0, 1e300], [-1e-12, math.nan]),
    ("(0, 1]", [1e-12, 1.0], [0.0, 1.0 + 1e-12]),
    ("(-inf, 2)", [-1e300, 1.999], [2.0]),
])
def test_an_interval_holds_its_values_and_no_others(text, inside, outside):
    interval = Interval.parse(text)
    assert all(interval.contains(v, None) for v in inside)
    assert not any(interval.contains(v, None) for v in outside)
    assert interval.describe() == text


def test_interval_notation_errors():
    for text in ("0, 1", "[0; 1]", "[0, 1 + x]", "{0, 1}"):
        with pytest.raises(ValueError):
            Interval.parse(text)


def test_one_error_line_names_the_class_field_value_and_range():
    with pytest.raises(LegplanError, match=r"^example parameter 'low' out of range: -1 \(allowed \[0, inf\)\)$"):
        _Example(low=-1)
    with pytest.raises(LegplanError, match=r"^example parameter 'high' out of range: 3 \(allowed \(low = 3, 10\]\)$"):
        _Example(low=3, high=3)
    with pytest.raises(LegplanError, match=r"'mode' out of range: 'c' \(allowed 'a', 'b'\)"):
        _Example(mode="c")
    assert _Example(maybe=None).maybe is None  # None: filled in later, not checked
    with pytest.raises(LegplanError, match="'maybe' out of range"):
        _Example(maybe=1.0)


def test_replace_and_as_dict():
    example = _Example().replace(low=0.5)
    assert example.as_dict() == {"low": 0.5, "high": 2.0, "maybe": None, "mode": "a"}
    with pytest.raises(LegplanError, match="'high' out of range"):
        example.replace(high=0.5)


def test_the_declaration_carries_symbol_and_doc():
    low = {f.name: f for f in dataclasses.fields(_Example)}["low"]
    assert low.default == 1.0 and low.metadata["symbol"] == "ℓ" and low.metadata["doc"] == "a length"


def test_inherit_copies_default_and_metadata_and_replaces_what_is_given():
    @dataclass(frozen=True)
    class Copy:
        low: float = inherit(_Example, "low")
        high: float = inherit(_Example, "high", range="[0, 5]")

    fields = {f.name: f for f in dataclasses.fields(Copy)}
    assert fields["low"].default == 1.0 and fields["low"].metadata["range"] == Interval.parse("[0, inf)")
    assert fields["low"].metadata["doc"] == "a length"
    assert fields["high"].metadata["range"] == Interval.parse("[0, 5]")


def test_the_step_baseline_solves_the_step_planners_problem():
    plan, baseline = StepPlanParams(), StepBaselineParams()
    for name in ("epsilon", "slack_fraction", "clearance", "relax_radius", "com_margin", "judge_tolerance"):
        assert getattr(baseline, name) == getattr(plan, name)
    with pytest.raises(LegplanError, match="step baseline parameter 'epsilon' out of range"):
        StepBaselineParams(epsilon=0.0)  # was accepted before it inherited the planner's range
    with pytest.raises(LegplanError, match="'dense_samples' out of range: 3"):
        StepBaselineParams(dense_samples=3)  # third differences need 4 (the planner takes 2)


def test_choices_are_ranges_too():
    with pytest.raises(LegplanError, match=r"^nav baseline parameter 'planner' out of range: 'rrt' \(allowed 'rrtconnect'"):
        NavBaselineParams(planner="rrt")
    with pytest.raises(LegplanError, match=r"^step baseline parameter 'space' out of range: 'flat'"):
        StepBaselineParams(space="flat")


def _just_outside(interval: Interval, params):
    """A value just below the low bound or just above the high one, or None if both are infinite."""
    low, high = (getattr(params, b) if isinstance(b, str) else b for b in (interval.low, interval.high))
    if math.isfinite(low):
        return low if interval.low_open else low - max(1e-9, abs(low) * 1e-9)
    if math.isfinite(high):
        return high if interval.high_open else high + max(1e-9, abs(high) * 1e-9)
    return None


@pytest.mark.parametrize("cls", PARAMETER_CLASSES, ids=lambda c: c.__name__)
def test_every_declared_range_is_enforced(cls):
    defaults = cls()
    ranged = [f for f in dataclasses.fields(cls) if isinstance(f.metadata.get("range"), Interval)]
    assert ranged, f"{cls.__name__} declares no range"
    for f in ranged:
        assert getattr(defaults, f.name) is None or f.metadata["range"].contains(getattr(defaults, f.name), defaults)
        bad = _just_outside(f.metadata["range"], defaults)
        if bad is None:
            continue
        if f.type in (int, "int"):
            bad = math.floor(bad) if bad < getattr(defaults, f.name) else math.ceil(bad)
        with pytest.raises(LegplanError, match=f"parameter '{f.name}' out of range"):
            dataclasses.replace(defaults, **{f.name: bad})
