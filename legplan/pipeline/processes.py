"""The stage processes of one pipeline run: started so that they never outlive the pipeline.

Each stage runs in its own process group (so a Ctrl-C at the terminal reaches the pipeline only, and
the pipeline can end a stage together with its worker processes), and calls
`legplan.interrupts.die_with_parent` first thing (`DIE_WITH_PARENT`, prefixed to the stage's
`python -c` snippet), so a SIGKILLed pipeline takes its stages with it. `stop()` — on SIGINT or
SIGTERM of the pipeline — sends SIGTERM to every running stage's group (the stage removes its
temporaries and publishes nothing), SIGKILL after `grace` seconds, and refuses to start new stages.
The parent-death signal is not set in a `preexec_fn`: stages are started from threads, where a
`preexec_fn` may deadlock the child.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time

from legplan.interrupts import PARENT_ENV

DIE_WITH_PARENT = "from legplan.interrupts import die_with_parent; die_with_parent()"


class StageProcesses:
    """Starts stage processes and stops them all at once (thread-safe)."""

    def __init__(self, grace: float = 10.0):
        self.grace = grace
        self._lock = threading.Lock()
        self._running: set[subprocess.Popen] = set()
        self._stopped = False

    def run(self, argv: list[str], *, stdout, env: dict) -> int | None:
        """Run `argv` to its end and return its exit code; None when `stop()` came first."""
        with self._lock:
            if self._stopped:
                return None
            process = subprocess.Popen(argv, stdout=stdout, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                       env={**env, PARENT_ENV: str(os.getpid())}, process_group=0)
            self._running.add(process)
        try:
            return process.wait()
        finally:
            with self._lock:
                self._running.discard(process)

    def stop(self) -> None:
        """SIGTERM every running stage's process group, SIGKILL what is left after `grace` s; no
        stage starts afterwards."""
        with self._lock:
            self._stopped = True
            processes = list(self._running)
        for process in processes:
            _signal_group(process, signal.SIGTERM)
        deadline = time.monotonic() + self.grace
        for process in processes:
            try:
                process.wait(timeout=max(deadline - time.monotonic(), 0))
            except subprocess.TimeoutExpired:
                _signal_group(process, signal.SIGKILL)
                process.wait()
            _signal_group(process, signal.SIGKILL)  # workers the stage left behind, if any


def _signal_group(process: subprocess.Popen, signum: int) -> None:
    try:
        os.killpg(process.pid, signum)
    except (ProcessLookupError, PermissionError):  # the group is gone already
        pass
