"""What a worker runs for one item: `Task`, a picklable wrapper of a planner's per-item function.

A worker (the calling process for `--jobs 1`, a pool process, a dask worker) builds the task's
context `setup(*args)` (robot, terrain, validator, ...) once, keeps it for every later item of an
equal task (per thread, so a multi-threaded dask worker never shares one), or takes over the one
the `--jobs N` fork server built before forking it (`build_shared`), and limits BLAS/OpenMP
to one thread once the context has loaded its libraries: parallelism comes from workers, and extra
BLAS threads only contend for the same cores (measured: +67 % CPU per step-plan item with 2
OpenBLAS threads in each of 2 workers on 2 cores, `BENCHMARKS.md`).
"""

from __future__ import annotations

import logging
import os
import pickle
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
WARM_ENV = "LEGPLAN_WARM_TASK"  # the file a prestarted fork server reads its task from (`legplan.batch.warmup`)
_local = threading.local()
# Inherited one-thread settings reached every BLAS/OpenMP library before it loaded: nothing to limit.
_limited = {"done": all(os.environ.get(name) == "1" for name in THREAD_VARIABLES)}


# The context the fork server built before forking the workers (`build_shared`): {"key", "value"}.
_shared: dict = {}


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
        """The context of this task in the current thread, built at its first item (or taken over
        from the process's fork server when it built this task's, `build_shared`)."""
        if getattr(_local, "key", None) != (self.setup, self.args):
            _local.key, _local.value = None, None  # drop the old context before building the new one
            shared = _take_shared(self)
            if shared is None and self.setup is not None:
                log.debug("task context: built in process %d", os.getpid())
            _local.value = shared if shared is not None or self.setup is None else self.setup(*self.args)
            _local.key = (self.setup, self.args)
            _limit_loaded_libraries()
        return _local.value

    def identity(self) -> bytes:
        """What makes two copies of this task (pickled to other processes) the same task: its setup and
        arguments, pickled."""
        return pickle.dumps((self.setup, self.args), protocol=4)

    def provide(self, context) -> None:
        """Make `context` this task's context in the calling thread, as if `setup(*args)` had built it:
        a caller that has already loaded what `setup` loads (to check its inputs) hands it over, so
        `--jobs 1` does not load it twice, and the `--jobs N` workers forked from this thread afterwards
        (`legplan.batch.fork_workers`) start with it. Other pool and dask workers build their own."""
        log.debug("task context: provided in process %d", os.getpid())
        _local.key, _local.value = (self.setup, self.args), context
        _limit_loaded_libraries()

    def __call__(self, item) -> dict:
        try:
            return self.run(self.context(), item)
        except Exception as exc:  # one bad item must not stop the batch
            log.debug("item raised:\n%s", traceback.format_exc())
            return self.failed(item, f"{type(exc).__name__}: {exc}")


def _take_shared(task: Task):
    """The context the fork server built, if it was built for `task` (once: it is dropped either way)."""
    if not _shared:
        return None
    key, value = _shared.pop("key"), _shared.pop("value")
    return value if key == task.identity() else None


def build_shared(task: Task) -> None:
    """Build `task`'s context in this process for the processes forked from it afterwards: the first
    item of `task` in each of them takes it over instead of calling `setup` again (`Task.context`).
    Run by the `--jobs N` fork server (`legplan.batch.warmup`)."""
    if task.setup is not None:
        _shared["value"] = task.setup(*task.args)
        _shared["key"] = task.identity()
        _limit_loaded_libraries()

