"""Terminal output for the CLI: logging and progress on stderr, so stdout stays clean for pipes.

Library code never prints; it logs through `logging` and reports progress through a callback
`progress(done, total, message)`, which `progress_bar` provides here.
"""

from __future__ import annotations

import logging
from contextlib import contextmanager

from rich.console import Console
from rich.logging import RichHandler
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.text import Text

stderr = Console(stderr=True)
_state = {"verbosity": 0}


def set_verbosity(level: int) -> None:
    """-1 quiet (errors only, no progress), 0 default (warnings), 1 info, 2+ debug."""
    _state["verbosity"] = level
    root = logging.getLogger("legplan")
    if not any(isinstance(handler, RichHandler) for handler in root.handlers):
        root.addHandler(RichHandler(console=stderr, show_path=False, show_time=False))
    root.setLevel({-1: logging.ERROR, 0: logging.WARNING, 1: logging.INFO}.get(level, logging.DEBUG))


def verbosity() -> int:
    return _state["verbosity"]


@contextmanager
def progress_bar(description: str):
    """Yields a `progress(done, total, message="")` callback drawing a bar on stderr (none if -q).

    The bar appears at the first update, so a command that fails before any work shows only its
    one-line error.
    """
    if verbosity() < 0:
        yield lambda done, total, message="": None
        return
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TextColumn("{task.fields[message]}"))
    bar = Progress(*columns, console=stderr, transient=False)
    task = bar.add_task(description, total=None, message="")

    def update(done: int, total: int, message: str = "") -> None:
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
        stderr.print(message, highlight=False, markup=False, soft_wrap=True)


def stderr_line(message: str, label: str = "", style: str = "bold red") -> None:
    """One line on stderr that is never wrapped (so it greps as one line) and never parsed as
    markup (paths and reasons may hold brackets): an optional styled `label`, then `message`.
    For errors, warnings, failed items and pipeline stage lines; shown even with -q."""
    line = Text(f"{label} ", style=style) if label else Text()
    line.append(message)
    stderr.print(line, highlight=False, soft_wrap=True)
