"""Shared pieces of the bad-input suite (`test_bad_input_*.py`, issue 18 classes 1-4).

The contract (README, "Exit codes"): bad input exits 2 with exactly one line on stderr that names
the file (or the option) and the field; nothing on stdout; no output file is created, an existing
one is left byte-identical, and no temporary file is left beside it.

`valid_inputs(dir)` writes one small valid artefact of each kind the commands read, so that a case
can break exactly one input and leave the others valid.
"""

from __future__ import annotations

import json
from pathlib import Path

import click
import h5py
import numpy as np
from click.testing import CliRunner
from hypothesis import HealthCheck, settings

from legplan.cli.main import cli
from legplan.cli.options import Numbers
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap

EXAMPLE_STEPS = Path(__file__).parents[1] / "data" / "steps_example.csv"
SENTINEL = b"an older output that a refused command must leave alone\n"


def few(examples: int):
    """Hypothesis settings of this suite: a few examples, no deadline (no timing asserts), the same
    examples every run (derandomized, no example database written into the checkout)."""
    return settings(max_examples=examples, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def invoke(args) -> click.testing.Result:
    return CliRunner().invoke(cli, [str(a) for a in args])


def assert_refused(result, *names: str, output: Path | None = None, before: bytes | None = None) -> str:
    """Exit 2, one `Error:` line on stderr holding every one of `names`, empty stdout; `output`
    absent (or still `before`), no temporary file beside it. Returns the line."""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2, f"exit {result.exit_code}: {result.stderr[-2000:]}"
    assert len(lines) == 1, f"{len(lines)} lines on stderr: {result.stderr[-2000:]}"
    assert lines[0].startswith("Error: "), lines[0]
    for name in names:
        assert name in lines[0], f"{name!r} not named in: {lines[0]}"
    assert result.stdout == "", result.stdout
    if output is not None:
        if before is None:
            assert not output.exists(), f"{output} was created"
        else:
            assert output.read_bytes() == before, f"{output} changed"
        stray = [p.name for p in output.parent.iterdir()
                 if p.name.startswith(f".{output.name}") or p.name.endswith((".tmp", ".work"))]
        assert not stray, f"left behind: {stray}"
    return lines[0]


def leaf_commands(group: click.Group = cli, path: tuple[str, ...] = ()):
    """(path, command) of every runnable command of the click tree (each loaded, as on first use)."""
    ctx = click.Context(group)
    for name in sorted(group.list_commands(ctx)):
        command = group.get_command(ctx, name)
        if isinstance(command, click.Group):
            yield from leaf_commands(command, (*path, name))
        else:
            yield (*path, name), command


def valid_inputs(directory: Path) -> dict[str, Path]:
    """One small valid input of each kind: map.h5 (2 x 2 m flat at 2 cm), steps.h5 (the example
    CSV imported), motion.h5 (its first step planned), nav.h5 (one query searched), traj.h5 (a
    2-stride anymal trot planned), and a copy of the example steps CSV."""
    paths = {name: directory / f"{name}.h5" for name in ("map", "steps", "motion", "nav", "traj")}
    grid = Grid2D(origin=(-0.99, -0.99), resolution=0.02, shape=(100, 100))
    save_map(terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat"), paths["map"])
    commands = [
        ["steps", "import", EXAMPLE_STEPS, "--robot", "scarab2", "--map", paths["map"], "-o", paths["steps"]],
        ["step", "plan", paths["map"], paths["steps"], "--steps", "0", "-o", paths["motion"]],
        ["nav", "search", paths["map"], "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5", "-o", paths["nav"]],
        ["dyn", "plan", paths["map"], "--start", "0", "0", "0", "--goal", "0.3", "0", "0", "--strides", "2",
         "--duration", "1.6", "-o", paths["traj"]],
    ]
    for args in commands:
        result = invoke([*args, "-q"])
        assert result.exit_code == 0, result.stderr
    paths["csv"] = directory / "steps.csv"
    paths["csv"].write_bytes(EXAMPLE_STEPS.read_bytes())
    paths["state"] = directory / "state.yaml"  # the traj's own state at its middle sample, for `dyn replan`
    with h5py.File(paths["traj"], "r") as handle:
        samples = {name: handle[f"tasks/0000/samples/{name}"][()] for name in
                   ("t", "base_pos", "base_euler", "base_vel", "base_ang_vel", "feet_pos")}
    k = len(samples["t"]) // 2
    state = {"t": float(samples["t"][k]), "task": 0,
             **{name: samples[name][k].tolist() for name in ("base_pos", "base_euler", "base_vel", "base_ang_vel",
                                                              "feet_pos")}}
    paths["state"].write_text(json.dumps(state))
    return paths


def mutated(source: Path, target: Path, dataset: str, change) -> Path:
    """A copy of artefact `source` at `target` with `change(array) -> array | None` applied to
    `dataset` (None deletes it)."""
    target.write_bytes(source.read_bytes())
    with h5py.File(target, "r+") as f:
        values = change(f[dataset][()])
        attrs = dict(f[dataset].attrs)
        del f[dataset]
        if values is not None:
            f.create_dataset(dataset, data=values)
            f[dataset].attrs.update(attrs)
    return target


def with_value(index, value):
    """A `mutated` change that sets one element (flat `index`, wrapped into range) to `value`."""
    def change(array):
        array = np.array(array, dtype=float)
        array.flat[index % array.size] = value
        return array
    return change


# The numeric options of the whole click tree (the option tests enumerate them).
def element_types(param) -> list:
    return list(param.type.types) if isinstance(param.type, click.Tuple) else [param.type]


def _is_float_option(param) -> bool:
    return isinstance(param, click.Option) and any(
        isinstance(t, (click.types.FloatParamType, Numbers)) for t in element_types(param))


def _is_int_option(param) -> bool:
    return (isinstance(param, click.Option) and not param.count
            and any(isinstance(t, click.types.IntParamType) for t in element_types(param)))


FLOAT_OPTIONS = [(path, command, param) for path, command in leaf_commands()
                 for param in command.params if _is_float_option(param)]
INT_OPTIONS = [(path, command, param) for path, command in leaf_commands()
               for param in command.params if _is_int_option(param)]


def option_ids(cases):
    return [f"{' '.join(path)} {param.opts[-1]}" for path, _, param in cases]


def count_of(param) -> int:
    if isinstance(param.type, Numbers):
        return min(param.type.counts)
    return len(param.type.types) if isinstance(param.type, click.Tuple) else max(param.nargs, 1)


def valid_value(kind) -> str:
    """A value `kind` accepts: inside its range, away from the bounds."""
    low, high = getattr(kind, "min", None), getattr(kind, "max", None)
    if low is not None and high is not None:
        return str((low + high) // 2 if isinstance(kind, click.IntRange) else (low + high) / 2)
    if low is not None:
        return str(low + 1)
    return str(high - 1) if high is not None else "0.5"


def command_line(path, command, param, values: list[str], tmp_path) -> list[str]:
    """`path` with placeholders for every other required parameter and `param` given `values`."""
    args = [*path]
    for other in command.params:
        if other is param or not other.required:
            continue
        kind = element_types(other)[0]
        text = (kind.choices[0] if isinstance(kind, click.Choice)
                else valid_value(kind) if isinstance(kind, (click.types.FloatParamType, click.types.IntParamType, Numbers))
                else str(tmp_path / "placeholder.h5"))
        filler = [text] * count_of(other)
        args += filler if isinstance(other, click.Argument) else [other.opts[-1], *filler]
    return [*args, param.opts[-1], *values]
