"""The `legplan` command: a click group whose subcommands are registered one module per group.

Exit codes: 0 success; 1 the command ran but some items failed (their reasons are in the artefact);
2 bad input (usage error, unreadable or invalid input); 130 / 143 interrupted by SIGINT / SIGTERM
(nothing published; a batch keeps its work file). User errors print one line, no traceback unless `-v`.
"""

from __future__ import annotations

import atexit
import importlib
import os
import sys
import threading
import traceback

import click

from legplan import __version__, interrupts
from legplan.cli.console import set_verbosity, stderr_line, verbosity
from legplan.cli.options import verbosity_opts
from legplan.errors import LegplanError

EXIT_ITEMS_FAILED = 1
EXIT_BAD_INPUT = 2

# One module per command group under legplan/cli/, each exposing `command` named as the module
# without its "_cmd" suffix; a module is imported only when its command is used (or listed by --help).
COMMAND_MODULES = ("inspect_cmd", "step_cmd", "pipeline_cmd", "robot_cmd", "steps_cmd", "map_cmd", "report_cmd", "nav_cmd", "compare_cmd", "baseline_cmd", "dyn_cmd", "learn_cmd")


class OneLineUsageError(click.ClickException):
    """A click usage error (bad option value, unknown option or command) shown as one line naming
    the command and the option, instead of click's usage, hint and message on four lines."""

    exit_code = EXIT_BAD_INPUT

    @classmethod
    def of(cls, error: click.UsageError, ctx: click.Context | None) -> OneLineUsageError:
        context = error.ctx or ctx
        where = f"{context.command_path}: " if context is not None else ""
        return cls(f"{where}{error.format_message()}")

    def show(self, file=None) -> None:
        stderr_line(self.format_message(), "Error:")


class LegplanGroup(click.Group):
    """Turns `LegplanError` (and OS errors on inputs) into a one-line message and exit code 2, and
    SIGINT / SIGTERM into exit 130 / 143 after cleanup. Subcommands of `COMMAND_MODULES` are imported
    when first looked up, so a command starts without importing every other command's libraries."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *(name.removesuffix("_cmd") for name in COMMAND_MODULES)})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.commands and f"{cmd_name}_cmd" in COMMAND_MODULES:
            self.add_command(importlib.import_module(f"legplan.cli.{cmd_name}_cmd").command)
        return super().get_command(ctx, cmd_name)

    def main(self, *args, **kwargs):
        """Every invocation runs under `interrupts.handle_interrupts`, argument parsing included."""
        with interrupts.handle_interrupts():
            return super().main(*args, **kwargs)

    def make_context(self, info_name, args, parent=None, **extra):
        if parent is None:
            set_verbosity(0)  # each invocation starts at the default; -v/-q callbacks adjust it
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.exceptions.NoArgsIsHelpError:
            raise
        except click.UsageError as exc:
            raise OneLineUsageError.of(exc, None) from exc
        except (KeyboardInterrupt, interrupts.Terminated) as exc:
            raise _stopped(exc) from None

    def invoke(self, ctx: click.Context):
        try:
            result = super().invoke(ctx)
            interrupts.raise_if_interrupted()  # a signal whose exception was swallowed on the way
            return result
        except click.exceptions.NoArgsIsHelpError:
            raise
        except click.UsageError as exc:
            raise OneLineUsageError.of(exc, ctx) from exc
        except (LegplanError, OSError) as exc:
            if verbosity() > 0:
                traceback.print_exc(file=sys.stderr)
            stderr_line(" ".join(str(exc).split()), "Error:")
            ctx.exit(EXIT_BAD_INPUT)
        except (KeyboardInterrupt, interrupts.Terminated) as exc:
            raise _stopped(exc) from None


def _stopped(error: BaseException) -> click.exceptions.Exit:
    """Say that SIGINT / SIGTERM stopped the command (and what it had published); exit 130 / 143."""
    stderr_line(interrupts.interrupted_message(), "Interrupted:")
    return click.exceptions.Exit(interrupts.exit_code(error))


@click.group(cls=LegplanGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="legplan")
@verbosity_opts
def cli():
    """Motion planning for legged robots: stages that read and write HDF5 artefacts.

    Stages chain through files, e.g.
    `legplan map build maps/gap_crossing.yaml -o map.h5` then
    `legplan steps generate map.h5 --robot scarab2 ... -o steps.h5`.
    """


def main() -> None:
    """The `legplan` console script: `cli`, then a quick exit. Once the command has finished, its
    output flushed and the `atexit` handlers run (logging, multiprocessing, h5py), the process ends
    without the interpreter's teardown of every imported module, which only frees memory and costs
    a short command a noticeable share of its CPU time. Other threads still running get the normal exit."""
    try:
        cli(prog_name="legplan")
        code = 0
    except SystemExit as exc:
        code = exc.code
    if threading.active_count() > 1:
        sys.exit(code)
    if code is not None and not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed or broken pipe: nothing more can be said
            pass
    os._exit(code or 0)
