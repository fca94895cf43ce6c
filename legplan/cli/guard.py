"""Rules every command obeys before it starts working, applied to the whole click tree in one place.

`guard_commands(cli)` wraps each leaf command's callback so that, after click parsed its arguments
and before the command's own code runs, its outputs are kept apart from its inputs
(`legplan.outputs_apart.refuse_overlap`): an output parameter is one of type `OutputPath`; an
input is any other parameter value that names an existing file, and the files of a robot folder
that a robot parameter resolves to. A violation is an `ArtefactError`: one line, exit 2, nothing
written.
"""

from __future__ import annotations

import functools
import os

import click

from legplan.outputs_apart import Input, Output, refuse_overlap
from legplan.cli.options import OutputPath

ROBOT_PARAMS = ("robot", "robot_name")  # parameters naming a robot (a name or a folder)


def _label(param: click.Parameter) -> str:
    if isinstance(param, click.Argument):
        return param.metavar or param.name.upper().removesuffix("_PATHS").removesuffix("_PATH")
    return max(param.opts, key=len)


def _values(value) -> list:
    if isinstance(value, (list, tuple)):
        return [item for entry in value for item in _values(entry)]
    return [value] if isinstance(value, (str, os.PathLike)) else []


def _robot_files(name: str) -> list[str]:
    from legplan.robots.registry import resolve_robot

    try:
        folder = resolve_robot(name).parent
        return [str(entry) for entry in folder.iterdir() if entry.is_file()]
    except Exception:  # an unknown or unreadable robot is the command's own error to report
        return []


def command_paths(ctx: click.Context) -> tuple[list[Output], list[Input]]:
    """The outputs and the existing input files that `ctx`'s parsed parameters name."""
    outputs, inputs = [], []
    for param in ctx.command.params:
        values = _values(ctx.params.get(param.name))
        if isinstance(param.type, OutputPath):
            outputs += [Output(_label(param), value, param.type.whole_directory, param.type.files)
                        for value in values]
            continue
        for value in values:
            if os.path.isfile(value):
                inputs.append(Input(_label(param), value))
            elif param.name in ROBOT_PARAMS:
                inputs += [Input(_label(param), path) for path in _robot_files(value)]
    return outputs, inputs


def _guarded(callback):
    @functools.wraps(callback)
    def run(*args, **kwargs):
        refuse_overlap(*command_paths(click.get_current_context()))
        return callback(*args, **kwargs)
    return run


def guard_commands(command: click.Command) -> None:
    """Wrap every leaf command below `command` (itself included) with the rules above."""
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            guard_commands(sub)
    elif command.callback is not None and not getattr(command.callback, "__legplan_guarded__", False):
        command.callback = _guarded(command.callback)
        command.callback.__legplan_guarded__ = True
