"""SIGINT and SIGTERM, handled the same way in one place, and processes that die with their parent.

`handle_interrupts()` (the CLI entry point wraps every command in it) installs one handler for both
signals: it records which signal arrived, then raises `KeyboardInterrupt` (SIGINT) or `Terminated`
(SIGTERM) so that `finally` blocks and context managers remove temporary files. The record matters
because an exception raised inside some C callbacks is swallowed (h5py hands it to
`sys.unraisablehook` and carries on writing; within the block that hook stays silent about the
signal's own exception, so no "Exception ignored" traceback reaches the terminal): `raise_if_interrupted()`
raises again from the record, and the one publish
function (`legplan.artefacts.publish`) calls it immediately before its rename, so nothing is published
after a signal arrived. `exit_code()` is 130 for SIGINT and 143 for SIGTERM (128 + the signal).

`die_with_parent()` asks Linux to SIGKILL the calling process when the thread that started it ends
(prctl PR_SET_PDEATHSIG), so a stage or pool worker never outlives a SIGKILLed parent.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM)
PR_SET_PDEATHSIG = 1
PARENT_ENV = "LEGPLAN_PARENT_PID"
"""Set by a parent that wants its child to die with it (see `die_with_parent`)."""

_received: list[int] = []
_published: list[str] = []


class Terminated(BaseException):
    """SIGTERM, raised in the main thread like `KeyboardInterrupt` is for SIGINT."""


def exception_for(signum: int) -> BaseException:
    """The exception a signal raises: `KeyboardInterrupt` for SIGINT, `Terminated` for SIGTERM."""
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


def _on_signal(signum, frame):
    _received.append(signum)
    raise exception_for(signum)


def received() -> int | None:
    """The first SIGINT / SIGTERM that arrived since `handle_interrupts` started, or None."""
    return _received[0] if _received else None


def raise_if_interrupted() -> None:
    """Raise the signal's exception again if SIGINT or SIGTERM arrived (even if it was swallowed)."""
    if _received:
        raise exception_for(_received[0])


def note_published(path) -> None:
    """Record that `path` was published (a signal after that cannot take it back)."""
    _published.append(str(path))


def interrupted_message() -> str:
    """What an interrupted command says: nothing published, or what was before the signal."""
    if _published:
        return f"stopped after publishing {', '.join(_published)}"
    return "stopped; nothing published"


def exit_code(error: BaseException) -> int:
    """130 for SIGINT (`KeyboardInterrupt`), 143 for SIGTERM (`Terminated`)."""
    return 128 + (signal.SIGTERM if isinstance(error, Terminated) else signal.SIGINT)


@contextmanager
def handle_interrupts():
    """Within the block, SIGINT and SIGTERM set the record and raise (main thread only; elsewhere
    a no-op). The record of signals and of published paths starts empty; the previous handlers are
    restored afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, _on_signal) for signum in SIGNALS}
    previous_hook = sys.unraisablehook

    def unraisable(report) -> None:  # the signal's exception, swallowed in a C callback: re-raised later
        if not (_received and isinstance(report.exc_value, (KeyboardInterrupt, Terminated))):
            previous_hook(report)

    sys.unraisablehook = unraisable
    _received.clear()
    _published.clear()
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = previous_hook
        _received.clear()


def die_with_parent(parent: int | None = None) -> None:
    """SIGKILL this process when the thread that started it ends (Linux; elsewhere a no-op).

    `parent` (default: `$LEGPLAN_PARENT_PID` when set) closes the race of a parent that died before
    this call: if our parent is no longer that process, we exit at once.
    """
    inherited = os.environ.pop(PARENT_ENV, "")  # not passed on to our own children
    if parent is None and inherited:
        parent = int(inherited)
    import ctypes  # here only: `legplan --version` and the like start without it

    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: nothing to ask for
        return
    if parent is not None and os.getppid() != parent:
        os._exit(128 + signal.SIGKILL)
