"""Every stage of a pipeline checked against the click commands before any stage runs.

A stage's argv (command words, params rendered as options, `-o OUTPUT --overwrite`) is resolved in
the click tree of `legplan` (or of any click group given) and parsed by the command itself with
`make_context`: unknown commands, unknown options, missing arguments, bad values and choices are
found at once, as one `SpecError` naming the pipeline file and the stage (exit 2), instead of after
the earlier stages ran. Nothing is invoked; the inputs need not exist yet (input paths are
`click.Path(exists=False)`), so a stage reading an earlier stage's output is checked too.
"""

from __future__ import annotations

import os

import click

from legplan.errors import SpecError
from legplan.pipeline.plan import resolve_stage
from legplan.pipeline.spec import Pipeline


def check_stage_commands(pipeline: Pipeline, out_dir: str | os.PathLike, group: click.Group) -> None:
    """`SpecError` "PIPELINE: stage 'NAME': PROBLEM" for the first stage `group` would refuse."""
    for spec in pipeline.stages:
        problem = command_problem(group, list(resolve_stage(pipeline, spec, out_dir).argv))
        if problem:
            raise SpecError(f"{pipeline.path}: stage '{spec.name}': {problem}")


def command_problem(group: click.Group, argv: list[str]) -> str | None:
    """What `group` would refuse in `argv` (the words after the program name), or None."""
    ctx = click.Context(group, info_name="legplan")
    command: click.Command = group
    words = list(argv)
    while isinstance(command, click.Group):
        if not words or words[0].startswith("-"):  # options come after the command words
            return f"'{ctx.command_path}' needs a subcommand ({', '.join(command.list_commands(ctx))})"
        name = words.pop(0)
        found = command.get_command(ctx, name)
        if found is None:
            return f"unknown command '{ctx.command_path} {name}'"
        command = found
        if isinstance(command, click.Group):
            ctx = click.Context(command, info_name=name, parent=ctx)
    try:
        with command.make_context(name, words, parent=ctx):
            return None
    except click.UsageError as exc:
        where = f"{exc.ctx.command_path}: " if exc.ctx is not None else ""
        return where + " ".join(exc.format_message().split())
    except click.exceptions.Exit:
        return f"'{ctx.command_path} {name}' would only print its help or version"
