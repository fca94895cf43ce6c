"""What a worker runs for one item: `Task`, a picklable wrapper of a planner's per-item function.

A worker (the calling process for `--jobs 1`, a pool process, a dask worker) builds the task's
context `setup(*args)` (robot, terrain, validator, ...) once, keeps it for every later item of an
equal task (per thread, so a multi-threaded dask worker never shares one), and limits BLAS/OpenMP
to one thread once the context has loaded its libraries: parallelism comes from workers, and extra
BLAS threads only contend for the same cores (measured: +67 % CPU per step-plan item with 2
OpenBLAS threads in each of 2 workers on 2 cores, `BENCHMARKS.md`).
"""

from __future__ import annotations

import logging
import os
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_local = threading.local()
# Inherited one-thread settings reached every BLAS/OpenMP library before it loaded: nothing to limit.
_limited = {"done": all(os.environ.get(name) == "1" for name in THREAD_VARIABLES)}


def one_thread_environment() -> None:
    """BLAS/OpenMP thread counts of 1 in this process's environment (read by libraries that load
    later, and inherited by processes started from here)."""
    for name in THREAD_VARIABLES:
        os.environ[name] = "1"


def _limit_loaded_libraries() -> None:
    """One thread in every BLAS/OpenMP library loaded so far (threadpoolctl), once per process."""
    if not _limited["done"]:
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1)
        _limited["done"] = True


@dataclass(frozen=True)
class Task:
    """`task(item)` returns `run(setup(*args), item)`, a record dict (see `legplan.batch`).

    `run`, `failed` and `setup` must be module-level functions or classes (picklable by reference);
    `args` and items picklable values. A raising `run` or `setup` gives `failed(item, reason)`
    with reason "ExceptionType: message"; the batch layer also calls `failed(item, "worker died
    ...")` for an item whose worker was lost twice. `failed` must not raise.
    """

    run: Callable[[Any, Any], dict]
    failed: Callable[[Any, str], dict]
    setup: Callable[..., Any] | None = None
    args: tuple = field(default=())

    def context(self):
        """The context of this task in the current thread, built at its first item."""
        if getattr(_local, "key", None) != (self.setup, self.args):
            _local.key, _local.value = None, None  # drop the old context before building the new one
            _local.value = None if self.setup is None else self.setup(*self.args)
            _local.key = (self.setup, self.args)
            _limit_loaded_libraries()
        return _local.value

    def provide(self, context) -> None:
        """Make `context` this task's context in the calling thread, as if `setup(*args)` had built it:
        a caller that has already loaded what `setup` loads (to check its inputs) hands it over, so
        `--jobs 1` does not load it twice. Pool and dask workers still build their own."""
        _local.key, _local.value = (self.setup, self.args), context
        _limit_loaded_libraries()

    def __call__(self, item) -> dict:
        try:
            return self.run(self.context(), item)
        except Exception as exc:  # one bad item must not stop the batch
            log.debug("item raised:\n%s", traceback.format_exc())
            return self.failed(item, f"{type(exc).__name__}: {exc}")
