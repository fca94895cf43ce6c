"""A many-item stage's run through `legplan.batch`: progress bar, interrupt message, publishing.

    records, summary = run_stage(task, items, "planning steps", output=output, identity=...,
                                 inputs=[...], jobs=jobs, scheduler=scheduler, resume=resume,
                                 overwrite=overwrite, publish=lambda records: write_motion(output, records, ...))

Every such stage starts its `--jobs N` workers the same way: `run_stage` builds the task's context in
the command (its inputs already read) and forks the workers from it (`legplan.batch.fork_workers`)
before it starts the progress bar's thread.

Ctrl-C (exit 130) or SIGTERM (exit 143) stops the batch, publishes nothing, keeps OUTPUT.work and
says that the same command with `--resume` continues it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from legplan.cli.console import progress_bar, stderr_line


def run_stage(task, items: Sequence, description: str, *, output, identity: Mapping, inputs: Sequence,
              jobs: int, scheduler: str | None, resume: bool, overwrite: bool, publish: Callable):
    """Run `task` over `items` on the backend of `--jobs`/`--scheduler`, then `publish(records)`
    (the stage's atomic writer); returns (records in item order, what `publish` returned)."""
    from legplan.artefacts.provenance import inputs_read_once
    from legplan.batch import Backend, fork_workers, run_batch, work_path
    from legplan.interrupts import Terminated

    backend = Backend(jobs, scheduler)
    fork_workers(jobs, scheduler, task)  # before any thread: the workers start with the command's context
    try:
        with inputs_read_once(), progress_bar(f"{description} ({backend.describe()})") as progress, \
                run_batch(task, items, output=output, identity=identity, inputs=inputs, backend=backend,
                          resume=resume, overwrite=overwrite, progress=progress) as records:
            return records, publish(records)
    except (KeyboardInterrupt, Terminated):
        work = work_path(output)
        if work.exists():
            stderr_line(f"finished items are kept in {work}; the same command with --resume continues")
        raise
