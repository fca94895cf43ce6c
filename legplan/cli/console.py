"""Terminal output for the CLI: logging and progress on stderr, so stdout stays clean for pipes.

Library code never prints; it logs through `logging` and reports progress through a callback
`progress(done, total, message)`, which `progress_bar` provides here.
"""

from __future__ import annotations

import functools
import logging
from contextlib import contextmanager

from legplan.interrupts import raise_if_interrupted

# rich is imported on first output (`_stderr`), not at import: `legplan --help` and commands
# that print nothing do not pay for it (issue 19, start-up time).
_state = {"verbosity": 0}


@functools.cache
def _stderr():
    """The rich console on stderr, created on first use."""
    from rich.console import Console

    return Console(stderr=True)


class _LazyRichHandler(logging.Handler):
    """Logs through rich's `RichHandler` on `_stderr()`, built at the first record."""

    @functools.cached_property
    def rich(self) -> logging.Handler:
        from rich.logging import RichHandler

        return RichHandler(console=_stderr(), show_path=False, show_time=False)

    def emit(self, record: logging.LogRecord) -> None:
        self.rich.handle(record)


def set_verbosity(level: int) -> None:
    """-1 quiet (errors only, no progress), 0 default (warnings), 1 info, 2+ debug."""
    _state["verbosity"] = level
    root = logging.getLogger("legplan")
    if not any(isinstance(handler, _LazyRichHandler) for handler in root.handlers):
        root.addHandler(_LazyRichHandler())
    root.setLevel({-1: logging.ERROR, 0: logging.WARNING, 1: logging.INFO}.get(level, logging.DEBUG))


def verbosity() -> int:
    return _state["verbosity"]


@contextmanager
def progress_bar(description: str):
    """Yields a `progress(done, total, message="")` callback drawing a bar on stderr (none if -q).
    Each call first re-raises a SIGINT / SIGTERM whose exception was swallowed on the way
    (`legplan.interrupts`), so long work stops at its next step.

    The bar appears at the first update, so a command that fails before any work shows only its
    one-line error.
    """
    if verbosity() < 0:
        yield lambda done, total, message="": raise_if_interrupted()
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TextColumn("{task.fields[message]}"))
    bar = Progress(*columns, console=_stderr(), transient=False)
    task = bar.add_task(description, total=None, message="")

    def update(done: int, total: int, message: str = "") -> None:
        raise_if_interrupted()  # long work reports progress often: stop even if a signal's exception was lost
        if not bar.live.is_started:
            bar.start()
        bar.update(task, completed=done, total=total, message=message)

    try:
        yield update
    finally:
        if bar.live.is_started:
            bar.stop()


def status(message: str) -> None:
    """A one-line outcome of a producing command ("wrote map.h5: ..."): stderr, silenced by -q."""
    if verbosity() >= 0:
        _stderr().print(message, highlight=False, markup=False, soft_wrap=True)


def stderr_line(message: str, label: str = "", style: str = "bold red") -> None:
    """One line on stderr that is never wrapped (so it greps as one line) and never parsed as
    markup (paths and reasons may hold brackets): an optional styled `label`, then `message`.
    For errors, warnings, failed items and pipeline stage lines; shown even with -q."""
    from rich.text import Text

    line = Text(f"{label} ", style=style) if label else Text()
    line.append(message)
    _stderr().print(line, highlight=False, soft_wrap=True)
