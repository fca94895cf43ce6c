"""Terminal output for the CLI: logging and progress on stderr, so stdout stays clean for pipes.

Library code never prints; it logs through `logging` and reports progress through a callback
`progress(done, total, message)`, which `progress_bar` provides here for every command: a bar with
elapsed time and ETA when stderr is a terminal, and plain progress lines every
`PROGRESS_LINE_SECONDS` (with an ETA) when stderr is a file or a pipe, so a log shows that long
work is moving. `-q` silences both.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
from collections.abc import Callable
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


PROGRESS_LINE_SECONDS = 10.0
"""Seconds between two progress lines when stderr is not a terminal."""


def _clock_text(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


class ProgressLines:
    """Progress as plain lines for logs: one at the first update, then at most one per `interval`
    seconds (also while no update arrives, through `tick`), and the last state when closed.

    A line reads `planning steps: 12/40 (30 %), elapsed 0:01:02, ETA 0:02:25, <message>`. The ETA
    extrapolates the rate since the first update (so items resumed from a work file do not count
    as fast ones); it is `?` until a second count arrives.
    """

    def __init__(self, description: str, write: Callable[[str], None], *, interval: float = PROGRESS_LINE_SECONDS,
                 clock: Callable[[], float] = time.monotonic):
        self.description = description
        self.write = write
        self.interval = interval
        self.clock = clock
        self.started = clock()
        self.first: tuple[float, float] | None = None  # (time, done) of the first update
        self.state: tuple[float, float, str] | None = None  # (done, total, message) of the last update
        self.written_at: float | None = None
        self.written_state = None
        self.lock = threading.Lock()

    def update(self, done: float, total: float, message: str = "") -> None:
        with self.lock:
            now = self.clock()
            self.state = (done, total, message)
            if self.first is None:
                self.first = (now, done)
            if self.written_at is None or now - self.written_at >= self.interval:
                self._write(now)

    def tick(self) -> None:
        """Write the current state if no line was written for `interval` seconds."""
        with self.lock:
            now = self.clock()
            if self.state is not None and self.written_at is not None and now - self.written_at >= self.interval:
                self._write(now)

    def close(self) -> None:
        """Write the last state unless it is the last line already written."""
        with self.lock:
            if self.state is not None and self.state != self.written_state:
                self._write(self.clock())

    def eta(self, now: float) -> float | None:
        """Seconds left at the rate since the first update, None while unknown."""
        done, total, _ = self.state
        first_time, first_done = self.first
        if done <= first_done or now <= first_time or not total:
            return None
        return max(total - done, 0.0) * (now - first_time) / (done - first_done)

    def line(self, now: float) -> str:
        done, total, message = self.state
        parts = [f"{self.description}: {_count(done)}/{_count(total)}"]
        if total:
            parts[0] += f" ({100.0 * done / total:.0f} %)"
        parts.append(f"elapsed {_clock_text(now - self.started)}")
        if total and done >= total:
            parts.append("done")
        else:
            eta = self.eta(now)
            parts.append(f"ETA {'?' if eta is None else _clock_text(eta)}")
        if message:
            parts.append(message)
        return ", ".join(parts)

    def _write(self, now: float) -> None:
        self.write(self.line(now))
        self.written_at = now
        self.written_state = self.state


def _count(value: float | None) -> str:
    if value is None:
        return "?"
    return f"{value:g}" if isinstance(value, float) and not value.is_integer() else f"{int(value)}"


@contextmanager
def _line_progress(description: str):
    """`ProgressLines` on stderr with a daemon thread calling `tick`, so a log gets a line at least
    every `PROGRESS_LINE_SECONDS` even while one item takes minutes."""
    lines = ProgressLines(description, lambda text: stderr_line(text))
    stop = threading.Event()

    def heartbeat():
        while not stop.wait(min(1.0, lines.interval)):
            lines.tick()

    thread = threading.Thread(target=heartbeat, name="legplan-progress", daemon=True)
    thread.start()

    def update(done, total, message: str = "") -> None:
        raise_if_interrupted()
        lines.update(done, total, message)

    try:
        yield update
    finally:
        stop.set()
        thread.join()
        lines.close()


@contextmanager
def progress_bar(description: str):
    """Yields a `progress(done, total, message="")` callback showing progress on stderr: a bar
    with elapsed time and ETA on a terminal, `ProgressLines` when stderr is a file or a pipe,
    nothing with -q. Each call first re-raises a SIGINT / SIGTERM whose exception was swallowed on
    the way (`legplan.interrupts`), so long work stops at its next step.

    The bar (or the first line) appears at the first update, so a command that fails before any
    work shows only its one-line error.
    """
    if verbosity() < 0:
        yield lambda done, total, message="": raise_if_interrupted()
        return
    if not _stderr().is_terminal:
        with _line_progress(description) as update:
            yield update
        return
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                               TimeRemainingColumn)

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), TextColumn("{task.fields[message]}"))
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
