"""Capturing what native libraries write straight to file descriptor 2.

urdfdom (inside pinocchio's URDF parser) prints its parser errors to the process's stderr before
pinocchio raises, which would put raw lines above our one-line error. `captured_stderr()` points
descriptor 2 at a temporary file for the duration of a call and hands the text back, so the caller
can fold it into its own message or log it.

    with captured_stderr() as captured:
        model = pin.buildModelFromUrdf(path)
    captured.lines  # what urdfdom printed, stripped, without blank lines
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field


@dataclass
class CapturedStderr:
    """The stripped, non-blank lines written to descriptor 2 inside the block (set on exit)."""

    lines: list[str] = field(default_factory=list)


@contextmanager
def captured_stderr():
    """Redirect descriptor 2 to a temporary file inside the block; `.lines` holds what was written.

    Python-level `sys.stderr` is flushed before and after, so its output keeps its order. Not
    thread-safe with respect to other threads writing to stderr meanwhile (they are captured too)."""
    captured = CapturedStderr()
    sys.stderr.flush()
    saved = os.dup(2)
    with _sink() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield captured
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            text = sink.read().decode("utf-8", errors="replace")
            captured.lines = [line.strip() for line in text.splitlines() if line.strip()]


def _sink():
    """An anonymous temporary file: in memory where the system has `memfd_create` (no file-system
    entry, and the command does not import `tempfile`), else `tempfile.TemporaryFile`."""
    try:
        return os.fdopen(os.memfd_create("legplan-stderr", os.MFD_CLOEXEC), "w+b")
    except (AttributeError, OSError):
        import tempfile

        return tempfile.TemporaryFile(mode="w+b")
