"""`run_batch`: a task over items on a backend, streamed into the work file, records in item order."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import closing, contextmanager

from legplan.batch.backends import Backend
from legplan.batch.task import Task
from legplan.batch.workfile import WorkFile
from legplan.interrupts import raise_if_interrupted

log = logging.getLogger(__name__)


@contextmanager
def run_batch(task: Task, items: Sequence, *, output: str | os.PathLike, identity: Mapping,
              inputs: Sequence = (), backend: Backend = Backend(), resume: bool = False,
              overwrite: bool = False, progress: Callable[[int, int, str], None] | None = None):
    """Run `task` on every item not yet in the work file of `output`; yields all records in item
    order: those of this run as the task returned them (each also stored in the work file), resumed
    ones read back from it. The work file is removed when the block ends without an
    exception (publish the artefact inside it), and kept otherwise, for `resume`.

    `identity` (JSON-able: stage name, parameters) and `inputs` (files, by sha256) must match for
    `resume` to continue a work file. The backend is started first, so an unreachable scheduler
    fails before any file is written.
    """
    items = list(items)
    executor = backend.start()
    try:
        work = WorkFile.open(output, identity, inputs, items, resume=resume, overwrite=overwrite)
    except BaseException:
        executor.close()
        raise
    try:
        done = work.done()
        if done:
            log.info("resuming %s: %d of %d items already done", work.path, len(done), len(items))
        failed = sum(not r.get("success", True) for r in work.records()) if done else 0
        todo = [(position, item) for position, item in enumerate(items) if position not in done]
        count, clock = len(done), time.perf_counter()
        if progress is not None:
            progress(count, len(items), f"{len(done)} resumed" if done else "")
        fresh = {}
        with closing(executor.run(task, todo)) as finished:  # closed at once on an exception: workers stop
            for position, record in finished:
                work.add(position, record)
                fresh[position] = record
                raise_if_interrupted()  # h5py may have swallowed the signal's exception
                count += 1
                failed += not record.get("success", True)
                log.debug("item %d done (%d/%d, %.2f s since start)", position, count, len(items),
                          time.perf_counter() - clock)
                if progress is not None:
                    progress(count, len(items), f"{failed} failed")
        records = [fresh[position] if position in fresh else work.record(position) for position in range(len(items))]
    finally:
        executor.close()
        work.close()
    yield records
    work.remove()
