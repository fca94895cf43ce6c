"""Finite but absurd numbers and sizes (issue 35 classes 2 and 3), over the whole click tree and every
file reader: every numeric option has a finite physical range, every declared parameter a range,
and a number outside it (1e308, 1e-320, a duration of an hour and more, a yaw of 1e6) is refused
with one line naming the file or option and the field, before any work; a size beyond its budget
(strides, hidden units, tasks, samples) is refused before anything is allocated."""

from __future__ import annotations

import dataclasses
import importlib
import math
import pkgutil
import typing

import click
import pytest
from bad_input_support import (FLOAT_OPTIONS, INT_OPTIONS, assert_refused, command_line, count_of, element_types,
                               few, invoke, leaf_commands, valid_value)
from hypothesis import assume, given
from hypothesis import strategies as st

import legplan
from legplan.budget import LIMITS
from legplan.cli.options import FiniteFloat, Numbers
from legplan.parameters import MAGNITUDE, Interval, Parameters


def _parameter_classes() -> list[type]:
    for module in pkgutil.walk_packages(legplan.__path__, "legplan."):
        if not module.name.startswith(("legplan.cli", "legplan.robot_models")):
            try:
                importlib.import_module(module.name)
            except ImportError:  # optional back ends (none on this machine)
                pass
    found, todo = [], list(Parameters.__subclasses__())
    while todo:
        cls = todo.pop()
        found.append(cls)
        todo += cls.__subclasses__()
    return sorted({c for c in found if dataclasses.is_dataclass(c)}, key=lambda c: c.__qualname__)


PARAMETER_CLASSES = _parameter_classes()


def _numeric_fields(cls):
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if typing.get_origin(hints[f.name]) is tuple:  # a vector (not settable by --param)
            continue
        kinds = typing.get_args(hints[f.name]) or (hints[f.name],)
        numeric = [k for k in kinds if k in (int, float)]
        if numeric:
            yield f, numeric[0]


def _finite_bound(bound) -> bool:
    return isinstance(bound, str) or math.isfinite(bound)


def test_every_numeric_option_has_a_finite_physical_range():
    assert len(FLOAT_OPTIONS) >= 25 and len(INT_OPTIONS) >= 25
    for path, _, param in FLOAT_OPTIONS:
        for kind in element_types(param):
            ranges = kind.ranges if isinstance(kind, Numbers) else [kind]
            assert ranges, f"{' '.join(path)} {param.opts[-1]}: positions without a range"
            for r in ranges:
                assert isinstance(r, FiniteFloat) and math.isfinite(r.min) and math.isfinite(r.max), \
                    f"{' '.join(path)} {param.opts[-1]}: {r!r}"
    for path, _, param in INT_OPTIONS:
        if param.name in ("verbose",):  # -v counts
            continue
        assert param.type.max is not None, f"{' '.join(path)} {param.opts[-1]} has no upper bound"


def test_every_declared_number_has_a_range_and_every_count_a_finite_one():
    assert len(PARAMETER_CLASSES) >= 7
    for cls in PARAMETER_CLASSES:
        for f, kind in _numeric_fields(cls):
            allowed = f.metadata.get("range")
            assert allowed is not None, f"{cls.__qualname__}.{f.name} has no declared range"
            if kind is int and isinstance(allowed, Interval):
                assert _finite_bound(allowed.low) and _finite_bound(allowed.high), f"{cls.__qualname__}.{f.name}"


def _outside(kind: FiniteFloat, value: float) -> bool:
    low_ok = value > kind.min or (value == kind.min and not kind.min_open)
    high_ok = value < kind.max or (value == kind.max and not kind.max_open)
    return not (low_ok and high_ok)


ABSURD = st.one_of(st.sampled_from([1e308, -1e308, 1e-320, -1e-320, 5e-324, 1.7976931348623157e308]),
                   st.floats(min_value=1e16, max_value=1e308).flatmap(lambda v: st.sampled_from([v, -v])),
                   st.floats(allow_nan=False, allow_infinity=False))


@few(40)
@given(case=st.sampled_from(FLOAT_OPTIONS), value=ABSURD, position=st.integers(0, 3))
def test_a_finite_value_outside_any_options_range_is_refused(tmp_path_factory, case, value, position):
    path, command, param = case
    count = count_of(param)
    position = position % count
    kinds = element_types(param)
    kind = kinds[min(position, len(kinds) - 1)]
    if isinstance(kind, Numbers):
        kind = kind.ranges[min(position, len(kind.ranges) - 1)]
    assume(_outside(kind, value))
    tmp_path = tmp_path_factory.mktemp("range")
    values = [valid_value(kinds[min(i, len(kinds) - 1)]) for i in range(count)]
    values[position] = repr(value)
    result = invoke(command_line(path, command, param, values, tmp_path))
    assert_refused(result, f"'{param.opts[-1]}'", output=tmp_path / "placeholder.h5")


# Every reader of numbers in a file, as ({file suffix}, content with {v} for the number, the command
# around {file}, what the line names). {map}: a valid map.h5; {out}: the output that must not appear.
TASKS_HEADER = "start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw,duration"
FILE_NUMBERS = {
    "tasks CSV goal_yaw": (".csv", f"{TASKS_HEADER}\n0,0,0,0.3,0,{{v}},1.6\n",
                           ["dyn", "plan", "{map}", "--tasks", "{file}", "-o", "{out}"], "field 'goal_yaw'"),
    "tasks CSV duration": (".csv", f"{TASKS_HEADER}\n0,0,0,0.3,0,0,{{v}}\n",
                           ["dyn", "plan", "{map}", "--tasks", "{file}", "-o", "{out}"], "field 'duration'"),
    "tasks YAML start_x": (".yaml", "tasks:\n  - {{start_x: {v}, start_y: 0, start_yaw: 0, goal_x: 0.3, goal_y: 0, "
                           "goal_yaw: 0}}\n", ["dyn", "plan", "{map}", "--tasks", "{file}", "-o", "{out}"],
                           "field 'start_x'"),
    "costs leg_clearance": (".yaml", "leg_clearance: {v}\n", ["dyn", "plan", "{map}", "--start", "0", "0", "0",
                            "--goal", "0.3", "0", "0", "--costs", "{file}", "-o", "{out}"], "field 'leg_clearance'"),
    "costs force weight": (".yaml", "force: {v}\n", ["dyn", "plan", "{map}", "--start", "0", "0", "0",
                           "--goal", "0.3", "0", "0", "--costs", "{file}", "-o", "{out}"], "field 'force'"),
    "map spec resolution": (".yaml", "name: s\nresolution: {v}\nextent: {{x: [-1, 1], y: [-1, 1]}}\n",
                            ["map", "build", "{file}", "-o", "{out}"], "resolution"),
    "map spec extent": (".yaml", "name: s\nresolution: 0.05\nextent: {{x: [-1, {v}], y: [-1, 1]}}\n",
                        ["map", "build", "{file}", "-o", "{out}"], "extent.x"),
    "map spec primitive": (".yaml", "name: s\nresolution: 0.05\nextent: {{x: [-1, 1], y: [-1, 1]}}\nprimitives:\n"
                           "  - {{type: box, center: [0, 0], size: [0.2, 0.2], height: {v}}}\n",
                           ["map", "build", "{file}", "-o", "{out}"], "primitives[0]"),
    "queries CSV velocity": (".csv", "start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                             "-0.5,-0.5,{v},0,0.5,0.5,0,0\n",
                             ["nav", "search", "{map}", "--queries", "{file}", "-o", "{out}"], "field 'start_vx'"),
    "task space duration": (".yaml", "map: {mapfile}\ngait: trot\nstrides: 2\nduration: {v}\ncosts: none\n"
                            "start: {{x: -0.3, y: 0, yaw: 0}}\ngoal: {{x: 0, y: 0, yaw: 0}}\n",
                            ["learn", "dataset", "{file}", "--n", "2", "-o", "{out}"], "field 'duration'"),
    "task space start.yaw": (".yaml", "map: {mapfile}\ngait: trot\nstrides: 2\nduration: 2.4\ncosts: none\n"
                             "start: {{x: -0.3, y: 0, yaw: [0, {v}]}}\ngoal: {{x: 0, y: 0, yaw: 0}}\n",
                             ["learn", "dataset", "{file}", "--n", "2", "-o", "{out}"], "start.yaw"),
}
FILE_ABSURD = st.one_of(st.sampled_from([1e308, -1e308, 1e-320, 1e20, -1e16]),
                        st.floats(min_value=1e16, max_value=1e308), st.floats(min_value=1e-300, max_value=1e-31))


def _yaml_number(value: float) -> str:
    """A YAML 1.1 float literal (PyYAML needs the dot: "1e+308" would be a string)."""
    mantissa, exponent = f"{value:.6e}".split("e")
    return f"{mantissa}e{exponent}"


@few(40)
@given(case=st.sampled_from(sorted(FILE_NUMBERS)), value=FILE_ABSURD)
def test_an_absurd_number_in_any_input_file_names_the_file_and_field(inputs, tmp_path_factory, case, value):
    suffix, content, template, field = FILE_NUMBERS[case]
    tmp_path = tmp_path_factory.mktemp("file")
    bad = tmp_path / f"bad{suffix}"
    bad.write_text(content.format(v=_yaml_number(value), mapfile=inputs["map"]))
    out = tmp_path / "out.h5"
    args = [part.format(file=bad, map=inputs["map"], out=out) for part in template]
    assert_refused(invoke(args), bad.name, field, output=out)


PARAM_COMMANDS = {  # a command with --param, a valid line around it, and the class its keys set
    "step plan": (["step", "plan", "{map}", "{steps}", "--steps", "0"], "legplan.stepplan.params:StepPlanParams", ""),
    "nav search": (["nav", "search", "{map}", "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5"],
                   "legplan.nav.params:NavParams", ""),
    "steps generate": (["steps", "generate", "{map}", "--robot", "scarab2", "--start", "-0.05", "0", "0",
                        "--goal", "0.05", "0", "0"], "legplan.stepseq.generate:GenerateParams", ""),
    "nav simulate teb": (["nav", "simulate", "{map}", "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5"],
                         "legplan.nav.teb.params:TebParams", "teb."),
}


def _class(spec: str):
    module, name = spec.split(":")
    return getattr(importlib.import_module(module), name)


PARAM_CASES = [(command, f.name, kind) for command, (_, spec, _) in sorted(PARAM_COMMANDS.items())
               for f, kind in _numeric_fields(_class(spec))]


@few(40)
@given(case=st.sampled_from(PARAM_CASES), value=FILE_ABSURD, sign=st.sampled_from([1, -1]))
def test_an_absurd_param_value_names_the_parameter(inputs, tmp_path_factory, case, value, sign):
    command, key, kind = case
    template, _, prefix = PARAM_COMMANDS[command]
    text = str(int(sign * value)) if kind is int and value >= 1 else repr(sign * value)
    tmp_path = tmp_path_factory.mktemp("param")
    out = tmp_path / "out.h5"
    args = [part.format(map=inputs["map"], steps=inputs["steps"]) for part in template]
    result = invoke([*args, "--param", f"{prefix}{key}={text}", "-o", out])
    assert_refused(result, "--param", f"'{key}'", output=out)


def test_max_iterations_zero_is_refused(inputs, tmp_path):
    out = tmp_path / "out.h5"
    result = invoke(["step", "plan", inputs["map"], inputs["steps"], "--param", "max_iterations=0", "-o", out])
    assert_refused(result, "--param", "field 'max_iterations' must be in [1, 1e+06], got '0'", output=out)


def test_the_magnitude_rule_is_the_declared_one():
    assert MAGNITUDE == (1e-30, 1e15)


# Class 3: sizes refused before memory grows.
@few(12)
@given(strides=st.integers(2600, LIMITS["strides"]))
def test_strides_beyond_the_variable_budget_are_refused(inputs, tmp_path_factory, strides):
    tmp_path = tmp_path_factory.mktemp("strides")
    out = tmp_path / "traj.h5"
    result = invoke(["dyn", "plan", inputs["map"], "--start", "0", "0", "0", "--goal", "0.3", "0", "0",
                     "--strides", strides, "--duration", "10", "-o", out])
    assert_refused(result, "field 'strides'", "legplan.budget.VARIABLES", output=out)


@few(12)
@given(strides=st.integers(2600, 10 ** 12), where=st.sampled_from(["csv", "space"]))
def test_a_file_asking_for_too_many_strides_is_refused(inputs, tmp_path_factory, strides, where):
    tmp_path = tmp_path_factory.mktemp("sizes")
    out = tmp_path / "out.h5"
    if where == "csv":
        bad = tmp_path / "tasks.csv"
        bad.write_text(f"{TASKS_HEADER},strides\n0,0,0,0.3,0,0,10,{strides}\n")
        args = ["dyn", "plan", inputs["map"], "--tasks", bad, "-o", out]
    else:
        bad = tmp_path / "space.yaml"
        bad.write_text(f"map: {inputs['map']}\ngait: trot\nstrides: {strides}\nduration: 10.0\ncosts: none\n"
                       "start: {x: -0.3, y: 0, yaw: 0}\ngoal: {x: 0, y: 0, yaw: 0}\n")
        args = ["learn", "dataset", bad, "--n", "2", "-o", out]
    assert_refused(invoke(args), bad.name, "field 'strides'", output=out)


@few(12)
@given(sizes=st.lists(st.integers(1, 10 ** 9), min_size=2, max_size=3))
def test_hidden_layers_beyond_the_weight_budget_are_refused_before_training(inputs, tmp_path_factory, sizes):
    weights = sum((a + 1) * b for a, b in zip([1, *sizes], [*sizes, 1]))
    assume(weights > LIMITS["weights"])
    tmp_path = tmp_path_factory.mktemp("hidden")
    out = tmp_path / "init.h5"
    result = invoke(["learn", "train", inputs["map"], "--hidden", ",".join(map(str, sizes)), "-o", out])
    assert_refused(result, "--hidden", "legplan.budget.WEIGHTS", output=out)


@few(10)
@given(path=st.sampled_from(sorted({p for p, _, param in INT_OPTIONS if param.name in ("count", "cycles",
                                                                                       "strides", "max_moves")})))
def test_counts_beyond_their_budget_are_refused_by_every_count_option(tmp_path_factory, path):
    tmp_path = tmp_path_factory.mktemp("count")
    command = dict(leaf_commands())[path]
    for param in command.params:
        if isinstance(param, click.Option) and isinstance(param.type, click.IntRange) and param.type.max:
            result = invoke(command_line(path, command, param, [str(param.type.max + 1)], tmp_path))
            assert_refused(result, f"'{param.opts[-1]}'", output=tmp_path / "placeholder.h5")


@pytest.mark.parametrize("gait, strides, duration", [("trot", 2, 0.5), ("walk", 4, 1.2), ("trot", 6, 1.0)])
def test_optimize_phases_with_a_duration_too_short_for_the_phases_is_refused(inputs, tmp_path, gait, strides,
                                                                             duration):
    out = tmp_path / "traj.h5"
    result = invoke(["dyn", "plan", inputs["map"], "--start", "0", "0", "0", "--goal", "0.3", "0", "0",
                     "--gait", gait, "--strides", strides, "--duration", duration, "--optimize-phases", "-o", out])
    assert_refused(result, "field 'duration'", "too short to optimize the phases", output=out)


def test_compare_tolerance_of_an_absurd_size_is_refused(inputs):
    for tol, field in (("mean_time=1e400", "expected a finite number"), ("mean_time=1e300", "too large"),
                       ("x=-1", "out of range"), ("x=1e12%", "out of range")):
        assert_refused(invoke(["compare", inputs["map"], inputs["map"], "--tol", tol]), "--tol", field)


ROBOT_FIELDS = {  # a line of anymal's robot.yaml, its number replaced, and the field it sets
    "friction": ("friction: 0.5", "friction: {v}", "centroidal.friction"),
    "max_normal_force": ("max_normal_force: 1000.0", "max_normal_force: {v}", "centroidal.max_normal_force"),
    "sphere radius": ("radius: 0.13}", "radius: {v}}}", "spheres[0].radius"),
}


@few(12)
@given(case=st.sampled_from(sorted(ROBOT_FIELDS)),
       value=st.one_of(st.sampled_from([1e308, 1e20, 1e-320]), st.floats(min_value=1e7, max_value=1e300)))
def test_an_absurd_number_in_a_robot_yaml_names_the_file_and_field(tmp_path_factory, case, value):
    import shutil
    from pathlib import Path

    old, new, field = ROBOT_FIELDS[case]
    folder = tmp_path_factory.mktemp("robot") / "anymal"
    shutil.copytree(Path(__file__).parents[2] / "robots" / "anymal", folder)
    spec = folder / "robot.yaml"
    text = spec.read_text()
    assert old in text
    spec.write_text(text.replace(old, new.format(v=_yaml_number(value)), 1))
    assert_refused(invoke(["robot", "show", spec, "--json"]), "robot.yaml", field)
