"""The last import of a prestarted `--jobs N` fork server: the batch's task context, built once.

`backends.prestart` names a file in `$LEGPLAN_WARM_TASK` while it starts the server; the command
writes the pickled `Task` there once it runs its batch (an empty file when it runs none; it removes
the file's folder when it cannot write it) and this import waits for it, so the server has imported
every module of its preload list meanwhile, while the command read its inputs. The server then
builds the task's context (robot, terrain, validator, ...) once (`task.build_shared`), and every
worker it forks afterwards starts with it instead of building its own. A task that cannot be
unpickled or set up here, or that never came, leaves the workers to build (and report) it
themselves.
"""

import logging
import os
import pickle
import time

from legplan.batch.task import WARM_ENV, build_shared

POLL_SECONDS = 0.005


def _wait_and_build(path: str) -> None:
    # the server dies with the command, so this wait ends; a command that cannot write the file
    # removes its folder instead
    while not os.path.exists(path) and os.path.isdir(os.path.dirname(path)):
        time.sleep(POLL_SECONDS)
    try:
        with open(path, "rb") as stream:
            data = stream.read()
    except OSError:
        return
    if data:
        try:
            build_shared(pickle.loads(data))
        except Exception:  # noqa: BLE001  (the workers build it again and record the reason per item)
            logging.getLogger(__name__).debug("fork server: no shared task context", exc_info=True)


if os.environ.get(WARM_ENV):
    _wait_and_build(os.environ[WARM_ENV])
