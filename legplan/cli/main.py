"""The `legplan` command: a click group whose subcommands are registered one module per group.

Exit codes: 0 success; 1 the command ran but some items failed (their reasons are in the artefact);
2 bad input (usage error, unreadable or invalid input); 130 / 143 interrupted by SIGINT / SIGTERM
(nothing published; a batch keeps its work file); 141 (128 + SIGPIPE) the reader of stdout or stderr
closed its pipe (`legplan inspect motion.h5 | head`): the command stops without a message. User
errors print one line, no traceback unless `-v`.
"""

from __future__ import annotations

import atexit
import gc
import importlib
import os
import re
import select
import sys
import threading
import traceback

import click

from legplan import __version__, interrupts
from legplan.cli.console import set_verbosity, stderr_line, verbosity
from legplan.cli.guard import guard_commands
from legplan.cli.options import verbosity_opts
from legplan.errors import LegplanError, did_you_mean

EXIT_ITEMS_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_PIPE_CLOSED = 141

# One module per command group under legplan/cli/, each exposing `command` named as the module
# without its "_cmd" suffix; a module is imported only when its command is used (or listed by --help).
COMMAND_MODULES = ("inspect_cmd", "step_cmd", "pipeline_cmd", "robot_cmd", "steps_cmd", "map_cmd", "report_cmd",
                   "nav_cmd", "compare_cmd", "baseline_cmd", "dyn_cmd", "learn_cmd", "export_cmd")


class OneLineUsageError(click.ClickException):
    """A click usage error (bad option value, unknown option or command) shown as one line naming
    the command and the option, instead of click's usage, hint and message on four lines."""

    exit_code = EXIT_BAD_INPUT

    @classmethod
    def of(cls, error: click.UsageError, ctx: click.Context | None) -> OneLineUsageError:
        context = error.ctx or ctx
        where = f"{context.command_path}: " if context is not None else ""
        return cls(f"{where}{error.format_message()}{_command_hint(error, context)}")


def _command_hint(error: click.UsageError, context: click.Context | None) -> str:
    """For an unknown command, the closest full command paths (`steps plan` -> 'step plan')."""
    message = error.format_message()
    unknown = re.match(r"No such command '(.+?)'\.", message)
    if unknown is None or context is None or "did you mean" in message.lower():  # click's own hint
        return ""
    root = context.find_root()
    typed = [*context.command_path.split()[1:], unknown.group(1)]
    same_depth = [path for path in _command_paths(root.command, root) if len(path.split()) == len(typed)]
    return did_you_mean(" ".join(typed), same_depth)


def _command_paths(group: click.Group, ctx: click.Context, prefix: str = "") -> list[str]:
    """Every command path under `group` ("map build", "step plan", ...), groups included."""
    paths = []
    for name in group.list_commands(ctx):
        sub = group.get_command(ctx, name)
        path = f"{prefix}{name}"
        paths.append(path)
        if isinstance(sub, click.Group):
            paths.extend(_command_paths(sub, ctx, f"{path} "))
    return paths

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
            self.add_command(prepare_command(importlib.import_module(f"legplan.cli.{cmd_name}_cmd").command))
        return super().get_command(ctx, cmd_name)

    def main(self, *args, **kwargs):
        """Every invocation runs under `interrupts.handle_interrupts`, argument parsing included."""
        with interrupts.handle_interrupts():
            try:
                return super().main(*args, **kwargs)
            finally:
                _flush_stdout()  # help text and short outputs meet a closed pipe only here

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
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's last flush
            return result
        except click.exceptions.NoArgsIsHelpError:
            raise
        except click.UsageError as exc:
            raise OneLineUsageError.of(exc, ctx) from exc
        except BrokenPipeError as exc:
            if not _silence_closed_pipes():
                _bad_input(ctx, exc)
            ctx.exit(EXIT_PIPE_CLOSED)
        except (LegplanError, OSError) as exc:
            _if_signalled()
            _bad_input(ctx, exc)
        except (KeyboardInterrupt, interrupts.Terminated) as exc:
            raise _stopped(exc) from None
        except Exception:
            _if_signalled()
            raise


def _if_signalled() -> None:
    """A signal's exception that a C callback turned into another (h5py raises a TypeError for an
    exception inside its type converters): the command was interrupted, not faulty."""
    signum = interrupts.received()
    if signum is not None:
        raise _stopped(interrupts.exception_for(signum)) from None


def _bad_input(ctx: click.Context, error: Exception):
    """One line naming what was wrong (a traceback too with -v); exit 2."""
    if verbosity() > 0:
        traceback.print_exc(file=sys.stderr)
    stderr_line(" ".join(str(error).split()), "Error:")
    ctx.exit(EXIT_BAD_INPUT)


def _closed_pipe(stream) -> bool:
    """Whether `stream` is a pipe whose reader has gone (poll reports an error on its write end)."""
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (e.g. a test runner's buffer)
        return False
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(events & select.POLLERR for _, events in poller.poll(0))


def _flush_stdout() -> None:
    """Flush stdout; a pipe its reader closed ends the process quietly with `EXIT_PIPE_CLOSED`."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        if not _silence_closed_pipes():
            raise
        raise SystemExit(EXIT_PIPE_CLOSED) from None


def _silence_closed_pipes() -> bool:
    """When stdout or stderr is a pipe its reader closed (`| head`), point it at /dev/null so that
    nothing more (and no flush at exit) fails on it; False if neither is, i.e. the broken pipe was
    another one (a worker's) and is an error to report."""
    closed = [stream for stream in (sys.stdout, sys.stderr) if _closed_pipe(stream)]
    if closed:
        devnull = os.open(os.devnull, os.O_WRONLY)
        for stream in closed:
            os.dup2(devnull, stream.fileno())
        os.close(devnull)
    return bool(closed)


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


ABBREVIATIONS = ("Fig.", "Figs.", "Eq.", "eq.", "Eqs.", "Sec.", "Tab.", "No.", "e.g.", "i.e.", "cf.", "vs.", "etc.")
"""Words whose period does not end a sentence (a command's one-line help runs past them)."""


def short_help(command: click.Command, limit: int = 45) -> str:
    """A command's line in its group's list: the first sentence of its help (not cut at "Fig. 3"
    or "eq. 5" as click's rule cuts it), shortened to `limit` characters at a word."""
    import textwrap

    words = (command.help or "").partition("\n\n")[0].split()
    for i, word in enumerate(words):
        if (word.endswith(".") and word.lstrip("([") not in ABBREVIATIONS
                and (i + 1 == len(words) or not words[i + 1][0].islower())):
            words = words[:i + 1]
            break
    return textwrap.shorten(" ".join(words), max(limit, 10), placeholder="...", break_on_hyphens=False)


def _use_short_help(group: click.Group) -> None:
    """`short_help` for every command under `group` (one rule for every help listing)."""
    for sub in group.commands.values():
        if not sub.short_help:
            sub.get_short_help_str = lambda limit=45, sub=sub: short_help(sub, limit)
        if isinstance(sub, click.Group):
            _use_short_help(sub)


def prepare_command(command: click.Command) -> click.Command:
    """What every command gets when it is loaded: the short-help rule for its listings and the rules
    checked before it starts (`legplan.cli.guard`)."""
    if not command.short_help:
        command.get_short_help_str = lambda limit=45, command=command: short_help(command, limit)
    if isinstance(command, click.Group):
        _use_short_help(command)
    guard_commands(command)
    return command


YOUNG_OBJECTS = 10_000
"""Allocations between two collections of the youngest generation in the console script (Python's
default: 700). A command's imports and solves allocate many long-lived objects, which at the
default the collector traverses again and again in its older generations. Reference-counted
objects are freed as before; only reference cycles wait longer."""


def main() -> None:
    """The `legplan` console script: `cli`, then a quick exit. Once the command has finished, its
    output flushed and the `atexit` handlers run (logging, multiprocessing, h5py), the process ends
    without the interpreter's teardown of every imported module, which only frees memory and costs
    a short command a noticeable share of its CPU time. Other threads still running get the normal exit.
    The cyclic garbage collector runs less often (`YOUNG_OBJECTS`)."""
    _, older, oldest = gc.get_threshold()
    gc.set_threshold(YOUNG_OBJECTS, older, oldest)
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
