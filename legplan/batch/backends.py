"""Where the items of a batch run: in this process, a local process pool, or a dask cluster.

Each executor's `run(task, todo)` takes `(position, item)` pairs and yields `(position, record)` as
items finish (completion order); `close()` releases its workers. `Backend(jobs, scheduler).start()`
picks one: `scheduler` "local" (a dask LocalCluster of `jobs` one-thread worker processes on
127.0.0.1) or an address such as "tcp://host:8786" (a running dask scheduler); otherwise `jobs` 1
runs in this process and `jobs` N in N worker processes (`_worker_context`).
"""

from __future__ import annotations

import atexit
import importlib
import logging
import os
import pickle
import shutil
import signal
import threading
import uuid
from collections import Counter, deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from legplan.batch.task import THREAD_VARIABLES, WARM_ENV, Task, one_thread_environment
from legplan.errors import LegplanError
from legplan.interrupts import PARENT_ENV, die_with_parent

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

log = logging.getLogger(__name__)

LOST_WORKERS = 2  # an item whose worker died this many times is recorded as failed


class InProcess:
    """`--jobs 1`: every item in the calling process, one after another."""

    def run(self, task: Task, todo) -> Iterator[tuple[int, dict]]:
        for position, item in todo:
            yield position, task(item)

    def close(self) -> None:
        pass


def _init_pool_worker(parent: int | None, modules: Sequence[str] = ()) -> None:
    """In each pool process: one BLAS/OpenMP thread, Ctrl-C left to the parent (which stops the
    pool), and death with the parent (Linux), so a killed batch leaves no orphaned workers; then
    the `modules` the items will need are imported (see `prestart`). `parent` None: the process was
    forked by the fork server (`_worker_context`), its parent, which ends with the command (should
    it have ended already, the worker ends when it finds the command's pipes closed)."""
    one_thread_environment()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a forked worker must not inherit the command's handler
    die_with_parent(os.getppid() if parent is None else parent)
    for name in modules:
        importlib.import_module(name)


def _started() -> None:
    """The no-op item that makes a pool spawn a worker process."""


def _new_pool(jobs: int, modules: Sequence[str] = (), warm: str | None = None) -> ProcessPoolExecutor:
    from concurrent.futures import ProcessPoolExecutor

    context, parent = _worker_context(modules, warm)
    return ProcessPoolExecutor(jobs, mp_context=context, initializer=_init_pool_worker,
                               initargs=(parent, tuple(modules)))


def _worker_context(modules: Sequence[str], warm: str | None = None):
    """The start method of pool workers and the parent they check (`_init_pool_worker`).

    Where the platform has one, a fork server: one process started (spawned, so nothing of this
    process's open files or threads is inherited) with one BLAS/OpenMP thread, that imports
    `modules` once, then forks every worker of every pool of this command. A worker is then ready
    as soon as it is forked, instead of each booting an interpreter and importing the libraries
    itself. The server dies with the command (`legplan.batch.serverguard`; call this from the thread
    that runs the batch, as `run_batch` and `prestart` do), and its workers with it. With `warm` (a
    file the command will write, `prestart`), a server started now also builds the batch's task
    context before it forks any worker (`legplan.batch.warmup`). Elsewhere each worker is spawned."""
    import multiprocessing  # a pool only: `--jobs 1` starts without it (start-up time)

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn"), os.getpid()
    from multiprocessing import forkserver

    context = multiprocessing.get_context("forkserver")
    # read when the server starts; the guard first: the server dies with this process
    context.set_forkserver_preload(["legplan.batch.serverguard", "legplan.batch.backends", *modules,
                                    *(["legplan.batch.warmup"] if warm else [])])
    saved = {name: os.environ.get(name) for name in (*THREAD_VARIABLES, PARENT_ENV, WARM_ENV)}
    one_thread_environment()  # the server's environment, before it loads numpy's BLAS
    os.environ[PARENT_ENV] = str(os.getpid())
    os.environ.pop(WARM_ENV, None)
    if warm:
        os.environ[WARM_ENV] = warm
    try:
        forkserver.ensure_running()
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    return context, None


@dataclass
class _Prestarted:
    """A pool whose workers a helper thread is starting (`prestart`)."""

    pool: ProcessPoolExecutor
    jobs: int
    warm: Path | None = None
    thread: threading.Thread | None = None
    error: BaseException | None = None

    def start(self) -> None:
        self.thread = threading.Thread(target=self._start_workers, name="legplan-prestart", daemon=True)
        self.thread.start()

    def _start_workers(self) -> None:
        try:
            for _ in range(self.jobs):
                self.pool.submit(_started)  # a pool starts its processes as items arrive
        except BaseException as exc:  # noqa: BLE001  (reported by the pool that replaces this one)
            self.error = exc

    def take(self) -> ProcessPoolExecutor | None:
        """The pool once every worker has been started; None when starting them failed (the batch's
        own pool then meets, and reports, the same failure)."""
        if self.thread is not None:
            self.thread.join()
        if self.warm is not None:  # read by the server before it forked the first worker
            shutil.rmtree(self.warm.parent, ignore_errors=True)
        if self.error is None:
            return self.pool
        log.debug("prestarted workers failed: %r", self.error)
        _stop(self.pool)
        return None


_prestarted: dict[int, _Prestarted] = {}
_warm_files: list[Path] = []  # the files a prestarted fork server waits for (`legplan.batch.warmup`)


def _share_task(task: Task | None) -> None:
    """Write `task` (None: no task) to the file a prestarted fork server waits for, once: the server
    then builds its context for every worker it forks. Called before any pool is used (the server
    forks nothing before it has read the file)."""
    while _warm_files:
        path = _warm_files.pop()
        data = b""
        if task is not None:
            try:
                data = pickle.dumps(task, protocol=4)
            except Exception:  # noqa: BLE001  (the pool itself reports an unpicklable task)
                data = b""
        partial = path.with_name(path.name + ".part")
        try:
            partial.write_bytes(data)
            os.replace(partial, path)  # the server sees the whole file or none
        except OSError:  # the server also goes on, without a task, when the folder is gone
            shutil.rmtree(path.parent, ignore_errors=True)


def prestart(jobs: int, scheduler: str | None, modules: Sequence[str]) -> None:
    """Start the `jobs` worker processes of `--jobs N` (N > 1, no scheduler) now and have each import
    `modules`: a command calls this before it reads its inputs, so the workers boot (interpreter,
    imports) while it reads; the next `ProcessPool` of as many workers takes them over. Unused
    workers are stopped when the process exits.

    It returns at once: the fork server is spawned from this thread (it dies with this thread,
    `_worker_context`), and the workers are asked for from a helper thread, since starting a worker
    waits until the server has imported `modules`."""
    if jobs < 2 or scheduler is not None or jobs in _prestarted:
        return
    import tempfile

    try:
        warm = Path(tempfile.mkdtemp(prefix="legplan-warm-")) / "task"
        _warm_files.append(warm)
    except OSError:  # no temporary folder: the workers build their own contexts
        warm = None
    entry = _Prestarted(_new_pool(jobs, modules, None if warm is None else str(warm)), jobs, warm=warm)
    entry.start()
    _prestarted[jobs] = entry


def fork_workers(jobs: int, scheduler: str | None, task: Task) -> None:
    """Without a dask `scheduler`: build `task`'s context in this process, then (`jobs` > 1) fork the
    `jobs` workers of `--jobs N` from it now; the next `ProcessPool` of as many workers takes them over.

    A command calls this once it has read its inputs and made its batch's `Task`, before it starts
    any thread (a progress display): every worker then starts with the imports, the inputs and the
    context this process holds (copied on write), so no worker boots an interpreter, imports or
    builds the context, and the items start as soon as `--jobs 1` would start its first one. With
    `jobs` 1 it only builds the context (`Task.provide`). Where processes cannot be forked, or when
    this process already runs other threads (a fork copies no thread, and a lock one of them holds
    would stay held in the worker), or a `prestart` pool waits, the workers are started as before
    (`prestart`, or the batch's own pool); a context that cannot be built is left to the workers,
    which record the reason per item."""
    if scheduler is not None:  # dask workers build their own
        return
    try:
        task.context()
    except Exception:  # noqa: BLE001  (each item then reports it, as `Task.__call__` does)
        log.debug("task context not built before the batch", exc_info=True)
        return
    if jobs < 2 or jobs in _prestarted or threading.active_count() > 1:
        return
    import multiprocessing  # a pool only: `--jobs 1` starts without it (start-up time)

    if "fork" not in multiprocessing.get_all_start_methods():
        return
    from concurrent.futures import ProcessPoolExecutor

    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork"),
                               initializer=_init_pool_worker, initargs=(os.getpid(), ()))
    pool.submit(_started)  # a fork pool forks all its workers at the first item, in this thread
    log.debug("task context: %d workers forked from process %d", jobs, os.getpid())
    _prestarted[jobs] = _Prestarted(pool, jobs)


def _take_prestarted(jobs: int) -> ProcessPoolExecutor | None:
    entry = _prestarted.pop(jobs, None)
    return None if entry is None else entry.take()


@atexit.register
def _stop_prestarted() -> None:
    _share_task(None)  # a server still waiting for a task goes on (and its workers start) without one
    while _prestarted:
        _, entry = _prestarted.popitem()
        pool = entry.take()
        if pool is not None:
            _stop(pool)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Stop `pool` at once: its items in flight are not waited for."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):  # no public API in 3.11
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


class ProcessPool:
    """`--jobs N`: N worker processes (`_worker_context`: none inherits the command's open files or
    threads), at most 2N items in flight (one queued per worker, so no worker waits for the parent
    to hand it the next). When a worker dies the pool breaks and every item in flight is suspect:
    each is rerun alone in a fresh pool, where a death is its own; an item that lost `LOST_WORKERS`
    workers so is recorded as failed. The others go on in a fresh pool."""

    def __init__(self, jobs: int):
        self.jobs = jobs

    def run(self, task: Task, todo) -> Iterator[tuple[int, dict]]:
        _share_task(task)
        queue, suspects, lost = deque(todo), deque(), Counter()
        while queue or suspects:
            alone = bool(suspects)
            died = yield from self._round(task, deque([suspects.popleft()]) if alone else queue,
                                          1 if alone else 2 * self.jobs)
            if len(died) > 1:
                suspects.extend(died)
                continue
            for position, item in died:
                lost[position] += 1
                log.warning("item %d: its worker process died (%d of %d)", position, lost[position], LOST_WORKERS)
                if lost[position] >= LOST_WORKERS:
                    yield position, task.failed(item, f"worker died ({LOST_WORKERS} worker processes lost)")
                else:
                    suspects.append((position, item))

    def _round(self, task, source: deque, limit: int):
        """Run `source` on a fresh pool with at most `limit` items in flight; yields finished
        items, returns the items in flight when the pool broke (empty when all finished)."""
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        workers = min(limit, self.jobs)
        pool = _take_prestarted(workers) or _new_pool(workers)
        running: dict = {}
        try:
            while source or running:
                while source and len(running) < limit:
                    position, item = source.popleft()
                    running[pool.submit(task, item)] = (position, item)
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                broken = []
                for future in finished:
                    entry = running.pop(future)
                    if isinstance(future.exception(), BrokenProcessPool):
                        broken.append(entry)
                    else:
                        yield entry[0], future.result()
                if broken:
                    died, running = broken + list(running.values()), {}
                    return died
            return []
        finally:
            if running:  # interrupted: stop the workers now instead of waiting for their items
                _stop(pool)
            else:
                pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        pass


class DaskCluster:
    """dask.distributed: placement, retries of items whose worker died (a LocalCluster allows
    `LOST_WORKERS` - 1 retries; an external scheduler uses its own `allowed-failures`) and
    scale-out. Items finish in any order; a lost item arrives as a `KilledWorker` error."""

    def __init__(self, client, cluster=None):
        self.client = client
        self.cluster = cluster

    @classmethod
    def connect(cls, scheduler: str, jobs: int) -> DaskCluster:
        import dask
        from distributed import Client, LocalCluster

        if scheduler == "local":
            with dask.config.set({"distributed.scheduler.allowed-failures": LOST_WORKERS - 1}):
                cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address="127.0.0.1:0")  # loopback only, any free port
            return cls(Client(cluster), cluster)
        timeout = dask.config.get("distributed.comm.timeouts.connect")
        try:
            return cls(Client(scheduler, timeout=timeout))
        except (OSError, TimeoutError, ValueError) as exc:
            raise LegplanError(f"--scheduler {scheduler}: cannot reach a dask scheduler ({exc})") from None

    def run(self, task: Task, todo) -> Iterator[tuple[int, dict]]:
        from distributed import as_completed

        todo = list(todo)
        batch = uuid.uuid4().hex[:12]
        futures = self.client.map(task, [item for _, item in todo],
                                  key=[f"legplan-{batch}-{position}" for position, _ in todo])
        waiting = {future.key: entry for future, entry in zip(futures, todo)}
        try:  # results come in batches (fewer round trips than one `result()` per future)
            for future, result in as_completed(futures, with_results=True, raise_errors=False):
                position, item = waiting.pop(future.key)
                # by what came back, not by `future.status`: a CI run read a record whose future no
                # longer said "finished" (its worker had died after it finished)
                if isinstance(result, dict):  # a record (Task always returns one)
                    record = result
                else:
                    error = result[1] if isinstance(result, tuple) else result  # (type, exc, tb) or CancelledError
                    reason = f"{type(error).__name__}: {error}"
                    record = task.failed(item, f"worker died ({reason})" if type(error).__name__ == "KilledWorker"
                                         else reason)
                future.release()
                yield position, record
        finally:
            if waiting:
                self.client.cancel([future for future in futures if future.key in waiting])

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


@dataclass(frozen=True)
class Backend:
    """The CLI's `--jobs` and `--scheduler`: which executor `start()` returns."""

    jobs: int = 1
    scheduler: str | None = None

    def __post_init__(self):
        if self.jobs < 1:
            raise LegplanError(f"--jobs: expected at least 1, got {self.jobs}")
        if self.scheduler is not None and self.scheduler != "local" and "://" not in self.scheduler:
            raise LegplanError(f"--scheduler: expected 'local' or an address such as tcp://HOST:PORT, "
                               f"got {self.scheduler!r}")

    def start(self):
        if self.scheduler is not None:
            return DaskCluster.connect(self.scheduler, self.jobs)
        return InProcess() if self.jobs == 1 else ProcessPool(self.jobs)

    def describe(self) -> str:
        if self.scheduler == "local":
            return f"dask LocalCluster, {self.jobs} workers"
        if self.scheduler is not None:
            return f"dask scheduler {self.scheduler}"
        return "in-process" if self.jobs == 1 else f"{self.jobs} worker processes"
