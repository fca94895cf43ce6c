"""The registry of options shared by every command (rasterio `rio` style).

Use them as decorators so every command spells the same option the same way:
`@output_opt @overwrite_opt @jobs_opt @seed_opt @verbosity_opts`; a many-item stage takes
`@batch_opts` (`--jobs`, `--scheduler`, `--resume`, see `legplan.cli.batching`).

Every numeric option takes `number(RANGE)` (a finite float in a finite physical range, written as
`legplan.parameters` declares ranges, mostly one of its named quantities, the one its parameter
field declares too: `number(DURATION)`), `Numbers` through `NumbersOption`
(space-separated finite numbers, each position in its range: `--start X Y [YAW]`) or a
`count(QUANTITY)` (a whole number up to its `legplan.budget` limit), never a bare `float` or an
unbounded int: NaN, inf and absurd finite values are
refused on the command line (exit 2, one line naming the option) before any work starts.
`tests/cli/test_bad_input_options.py` and `tests/cli/test_bad_input_ranges.py` check every
command's options for it.
"""

from __future__ import annotations

import math

import click

from legplan.cli.console import set_verbosity, verbosity
from legplan.parameters import COORDINATE, YAW, Interval

MAX_SEED = 2 ** 32 - 1
"""The largest `--seed` (numpy's and HDF5's integer range)."""


class FiniteFloat(click.FloatRange):
    """A float option value that must be finite (no nan, inf) and within the bounds."""

    name = "finite float"

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return number


def number(allowed: str) -> FiniteFloat:
    """The type of a numeric option: finite, and within the interval `allowed` ("(0, 3600]", or a
    named quantity of `legplan.parameters`, e.g. `DURATION`), whose bounds must be finite numbers."""
    interval = Interval.parse(allowed)
    if not all(isinstance(b, float) and math.isfinite(b) for b in (interval.low, interval.high)):
        raise ValueError(f"an option's range must have finite bounds, not {allowed!r}")
    return FiniteFloat(min=interval.low, max=interval.high, min_open=interval.low_open,
                       max_open=interval.high_open)


def count(quantity: str, minimum: int = 1) -> click.IntRange:
    """The type of a count option: a whole number from `minimum` up to the size budget of `quantity`
    (`legplan.budget.LIMITS`: "items", "iterations", "strides", "workers")."""
    from legplan.budget import LIMITS

    return click.IntRange(minimum, LIMITS[quantity])


def pose(count: int = 3) -> tuple[FiniteFloat, ...]:
    """The types of `X Y [YAW]` (`count` 2 or 3): coordinates and a heading in their physical ranges."""
    return (number(COORDINATE), number(COORDINATE), number(YAW))[:count]


class Numbers(click.ParamType):
    """Space-separated finite numbers after an option, as many as one of `counts` (`NumbersOption`);
    a list of floats."""

    name = "numbers"

    def __init__(self, counts: tuple[int, ...], ranges: tuple[str, ...] = ()):
        self.counts = counts
        self.ranges = tuple(number(text) for text in ranges)  # per position; the last repeats

    def convert(self, value, param, ctx):
        tokens = list(value) if isinstance(value, (list, tuple)) else str(value).split()
        try:
            numbers = [float(text) for text in tokens]
        except (TypeError, ValueError):
            numbers = []
        if len(numbers) not in self.counts:
            self.fail(f"expected {' or '.join(map(str, self.counts))} finite numbers, got "
                      f"{' '.join(map(str, tokens))!r}", param, ctx)
        for text, v in zip(tokens, numbers):
            if not math.isfinite(v):
                self.fail(f"{str(text)!r} is not a finite number", param, ctx)
        if self.ranges:
            for i, text in enumerate(tokens):
                self.ranges[min(i, len(self.ranges) - 1)].convert(text, param, ctx)
        return numbers


class NumbersOption(click.Option):
    """An option followed by a variable count of numbers, e.g. `--start X Y [YAW]` (`counts` (2, 3)):
    the numbers after the option are taken while they parse as numbers, up to the largest count,
    so `--start 1 -2 --goal 3 4` and `--start 1 -2 0.5 --goal 3 4` both work; with `multiple`,
    once per occurrence. The one syntax of every pose option (`counts=(3,)` for a fixed pose); `ranges`
    the physical range of each position (default x, y, yaw; the last repeats)."""

    def __init__(self, *args, counts: tuple[int, ...], ranges: tuple[str, ...] = (COORDINATE, COORDINATE, YAW),
                 **kwargs):
        self.counts = counts
        super().__init__(*args, type=Numbers(counts, ranges), **kwargs)

    def add_to_parser(self, parser, ctx) -> None:
        super().add_to_parser(parser, ctx)
        most = max(self.counts)
        for name in self.opts:
            option = parser._long_opt.get(name) or parser._short_opt.get(name)
            store = option.process

            def process(value, state, store=store):
                tokens = [value]
                while len(tokens) < most and state.rargs and _is_number(state.rargs[0]):
                    tokens.append(state.rargs.pop(0))
                store(tuple(tokens), state)

            option.process = process


def _pose(ctx, param, value):
    return None if value is None else (*value, 0.0)[:3]


def pose_opt(*names: str, help: str, required: bool = False):
    """The one arity rule of a body pose: `X Y [YAW]` (m, m, rad), yaw 0 when left out; the
    command gets `(x, y, yaw)` or None. (A position is `X Y`, `NumbersOption` with counts (2,).)"""
    return click.option(*names, cls=NumbersOption, counts=(2, 3), required=required, default=None,
                        metavar="X Y [YAW]", callback=_pose, help=f"{help} (m, m, rad; yaw 0 if left out).")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class ShippedPath(click.ParamType):
    """An input file that may also name a shipped scenario of `kind` ("maps", "pipelines", "tasks"):
    `gap_crossing` or `maps/gap_crossing.yaml` from any directory (`legplan.shipped`). A bare name
    that is neither is refused here with the closest shipped names; a missing path is left to the
    command's reader, whose message names the file (and, in a pipeline, its field)."""

    name = "path"

    def __init__(self, kind: str):
        self.kind = kind

    def convert(self, value, param, ctx):
        from legplan.errors import LegplanError
        from legplan.shipped import resolve_shipped

        try:
            return str(resolve_shipped(value, self.kind))
        except LegplanError as exc:
            if "/" in str(value):
                return str(value)
            self.fail(str(exc), param, ctx)


def _set_verbose(ctx, param, value):
    if value:
        set_verbosity(max(verbosity(), 0) + value)
    return value


def _set_quiet(ctx, param, value):
    if value:
        set_verbosity(-1)
    return value


def verbosity_opts(func):
    """`-v/--verbose` (repeatable) and `-q/--quiet`; accepted on the group and on every command."""
    func = click.option("-q", "--quiet", is_flag=True, expose_value=False, is_eager=True,
                        callback=_set_quiet, help="Only errors; no progress bars.")(func)
    return click.option("-v", "--verbose", count=True, expose_value=False, is_eager=True,
                        callback=_set_verbose,
                        help="More log output (-vv for debug); tracebacks on errors.")(func)


def _key_values(ctx, param, values) -> dict[str, str]:
    overrides = {}
    for item in values:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", ctx=ctx, param=param)
        overrides[key.strip()] = value.strip()
    return overrides


def param_opt(help_text: str):
    """`--param KEY=VALUE` (repeatable), passed to the command as a dict `params` of strings."""
    return click.option("--param", "params", multiple=True, metavar="KEY=VALUE",
                        callback=_key_values, help=help_text)


class OutputPath(click.Path):
    """The type of every output path option: a `click.Path` that `legplan.cli.guard` recognizes as
    an output and keeps apart from the command's inputs (`legplan.outputs_apart`).
    `whole_directory`: a directory the command replaces whole; `files`: the names it writes into
    an output directory (then only those are compared with the inputs)."""

    def __init__(self, *, whole_directory: bool = False, files: tuple[str, ...] = (), **kwargs):
        super().__init__(**kwargs)
        self.whole_directory = whole_directory
        self.files = tuple(files)


output_opt = click.option("-o", "--output", required=True, type=OutputPath(dir_okay=False),
                          help="Output artefact (HDF5) or image path.")
overwrite_opt = click.option("--overwrite", is_flag=True, help="Replace an existing output.")
jobs_opt = click.option("-j", "--jobs", type=count("workers"), default=1, show_default=True,
                        help="Worker processes for independent items.")
SCHEDULER_VARIABLE = "LEGPLAN_SCHEDULER"
"""The environment variable a command's `--scheduler` falls back to: `legplan pipeline run
--scheduler` sets it for its stages, so every many-item stage of a pipeline runs on one dask
cluster. Where the items run does not change what they compute (same records whatever the
backend), so a pipeline's provenance does not record it."""


def check_scheduler(ctx, param, value):
    """A malformed address is refused as the option is read, before the command reads its inputs."""
    if value is not None:
        from legplan.batch.backends import Backend

        Backend(1, value)
    return value


scheduler_opt = click.option(
    "--scheduler", metavar="local|tcp://HOST:PORT", default=None, envvar=SCHEDULER_VARIABLE,
    callback=check_scheduler,
    help="Run the items on dask: 'local' starts a LocalCluster of --jobs workers on 127.0.0.1, "
         f"an address uses a running dask scheduler (workers with legplan installed, inputs readable). "
         f"Default: ${SCHEDULER_VARIABLE} if set.")
resume_opt = click.option("--resume", is_flag=True,
                          help="Continue the interrupted run kept in OUTPUT.work (same inputs and parameters).")


def batch_opts(func):
    """`--jobs`, `--scheduler`, `--resume` of a many-item stage (`legplan.batch`)."""
    return jobs_opt(scheduler_opt(resume_opt(func)))


seed_opt = click.option("--seed", type=click.IntRange(0, MAX_SEED), default=0, show_default=True,
                        help="Seed of every random choice; same inputs and seed, same artefact.")
def _resolve_init(ctx, param, value):
    from legplan.learn.initializers import resolve_init

    return resolve_init(value)


init_opt = click.option(
    "--init", "init", default="heuristic", show_default=True, metavar="heuristic|INIT.h5|SPACE",
    callback=_resolve_init,
    help="Initializer: the paper's Heuristic (A_h), a trained init.h5 (A_θ), or the name of a task space "
         "whose trained initializer ships with legplan (e.g. single_pallet_walk: `legplan learn shipped`).")
warm_stage_opt = click.option(
    "--warm-stage", type=click.Choice(["costs", "projection", "polish"]), default="costs", show_default=True,
    help="From a learned --init: optimize the costs under the constraints (costs), or only project the "
         "network's guess onto the constraints (projection: fewer iterations, the cost not optimized), or "
         "project it and optimize the costs only where the plan costs more than the network's training "
         "filter kept (polish).")
optimize_phases_opt = click.option(
    "--optimize-phases", is_flag=True,
    help="Optimize the phase durations of every foot too (2 more variables per footstep); without it the "
         "gait's timing, or a learned --init's predicted one, stays fixed.")
json_opt = click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON on stdout.")
input_artefact = click.Path(exists=False, dir_okay=False)
