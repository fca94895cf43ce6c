"""Batch execution of many independent items: one interface, three backends (ARCHITECTURE.md layer 4).

A planner exposes a picklable per-item function and never starts workers; a stage runs it through
`run_batch`, which streams finished items into a work file beside the output and yields every
record in item order, ready for the stage's writer:

    from legplan.batch import Backend, Task, run_batch

    task = Task(run=plan_item, failed=failed_item, setup=StepWorker, args=(robot, map_path, params))
    with run_batch(task, items, output="motion.h5", identity={"stage": "step plan", **params.as_dict()},
                   inputs=[map_path, steps_path], backend=Backend(jobs=2), progress=progress) as records:
        write_motion("motion.h5", records, ...)   # atomic write; the work file goes when this ends cleanly

A CLI command takes `@batch_opts` (`legplan.cli.options`: --jobs, --scheduler, --resume) and calls
`legplan.cli.batching.run_stage(task, items, description, ..., publish=writer)`, which wraps
`run_batch` with the progress bar and the resume hint on Ctrl-C / SIGTERM (exit 130 / 143).

Contract of the task (`Task`):
* `setup(*args)` builds the per-worker context (robot, terrain, ...) once per worker thread;
  `run(context, item) -> dict` plans one item; `failed(item, reason) -> dict` is the record of an
  item that raised ("ExceptionType: message") or whose worker died twice ("worker died ..."). All
  three module-level (picklable by reference); `args` and the items picklable and small.
* A record is a dict of str keys whose values are numpy arrays, numbers, bools, strings or nested
  such dicts (stored in the work file as datasets, attributes, groups; a resumed item's read back
  with numpy scalar types); `record["success"]` (when present) counts failures for the progress line.
* Same items in the same order, same records in the same order, whatever the backend or `--jobs`
  (records are ordered by item position, never by completion); only clock values may differ.

Every CLI stage starts its `--jobs N` workers one way: `run_stage` calls `fork_workers(jobs, scheduler,
task)` once the command has read its inputs and made its `Task` (a command that loaded the context's
robot, map, ... to check its inputs hands them over first, `Task.provide`): the context is built in
the command and the workers are forked from it (no fork server, no imports, no second context),
before the command starts any thread. `prestart(jobs, scheduler, modules)` is for a caller whose
inputs take long to read and whose context the command does not need itself: called before it reads
them, a fork server boots and imports `modules` meanwhile, then waits for the batch's `Task`, which
`run_batch` hands it (`legplan.batch.warmup`); it builds the context once and forks the workers with
it, and `run_batch` takes them over.

Backends (`Backend(jobs, scheduler)`, the CLI's `--jobs`, `--scheduler`): `jobs` 1 in-process;
`jobs` N a pool of N processes (forked by one fork server that imported the libraries once); `scheduler="local"` a dask LocalCluster of `jobs` one-thread
workers on 127.0.0.1; `scheduler="tcp://host:port"` a running dask scheduler (its workers need
legplan installed, the input paths readable and, for one BLAS thread each, `--nthreads 1`).
Every worker runs BLAS/OpenMP on one thread (`legplan.batch.task`).

Work file (`legplan.batch.workfile`): `<output>.work`, one group per finished item, flushed after
each. `resume=True` continues one started with the same identity, inputs and items (otherwise
refused with the reason); without it an existing work file is an error unless `overwrite`. An
exception or interrupt (KeyboardInterrupt) in or under `run_batch` keeps the work file.
"""

from legplan.batch.backends import Backend, fork_workers, prestart
from legplan.batch.run import run_batch
from legplan.batch.task import Task
from legplan.batch.workfile import work_path

__all__ = ["Backend", "Task", "fork_workers", "prestart", "run_batch", "work_path"]
