"""Picklable toy tasks of the batch tests: a context that logs every computed item to a file (so a
test can count what was recomputed), items that raise, and an item that kills its worker."""

from __future__ import annotations

import os
import signal
import time

import numpy as np


class Context:
    def __init__(self, log_path: str, crash_item: int = -1, delay: float = 0.0):
        self.log_path, self.crash_item, self.delay = log_path, crash_item, delay


def square(context: Context, item: int) -> dict:
    """Record of item i: i², a nested dict and an array; raises for item 3; kills its process
    (SIGKILL, like an out-of-memory kill) for `crash_item`."""
    with open(context.log_path, "a") as stream:
        stream.write(f"{item}\n")
    if item == context.crash_item:
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(context.delay)
    if item == 3:
        raise ValueError("three is not allowed")
    return {"index": item, "success": True, "reason": "", "value": float(item) ** 2,
            "path": np.arange(item + 1, dtype=float), "nested": {"flag": bool(item % 2), "name": f"item {item}"}}


def failed(item: int, reason: str) -> dict:
    return {"index": item, "success": False, "reason": reason}


def computed(log_path) -> list[int]:
    """Items computed so far, in the order the log got them."""
    return [int(line) for line in open(log_path).read().split()] if os.path.exists(log_path) else []


def whose(context: Context, item: int) -> dict:
    """Record of item i: the process that computed it and that process's parent."""
    return {"index": item, "success": True, "reason": "", "pid": os.getpid(), "parent": os.getppid()}
