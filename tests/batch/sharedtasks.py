"""A picklable toy task whose setup logs the process that ran it (the shared-context test)."""

from __future__ import annotations

import os


class Logged:
    def __init__(self, log_path: str):
        with open(log_path, "a") as stream:
            stream.write(f"{os.getpid()}\n")
        self.pid = os.getpid()


def built_by(context: Logged, item: int) -> dict:
    """Record of item i: which process built the context it ran with, and which ran it."""
    return {"index": item, "success": True, "reason": "", "built_by": context.pid, "pid": os.getpid(),
            "parent": os.getppid()}


def failed(item: int, reason: str) -> dict:
    return {"index": item, "success": False, "reason": reason}
