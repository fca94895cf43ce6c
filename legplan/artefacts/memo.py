"""Whole-file readers remembered for the life of a process, keyed by the file's identity.

A report reads one motion.h5 for its verdict, its per-item figures and its 3D scene, and each reader
walks every step group of the file. `by_file` runs such a reader once per file version: the key is
the file's real path, device, inode, modification time (ns) and size, so a file published anew
(`legplan.artefacts.publish` replaces it by a rename: a new inode) or rewritten is read again.
Callers get a deep copy, so a caller that edits its result cannot change another's.
"""

from __future__ import annotations

import copy
import functools
import os
from collections import OrderedDict

REMEMBERED = 4
"""Files remembered per reader (the inputs of one report)."""


def file_identity(path) -> tuple:
    """(real path, device, inode, mtime in ns, size) of `path`."""
    st = os.stat(path)
    return os.path.realpath(path), st.st_dev, st.st_ino, st.st_mtime_ns, st.st_size


def by_file(reader):
    """`reader(source)` remembered per file version; `source` is a path or an open h5py object (its
    file and its group name make the key)."""
    cache: OrderedDict = OrderedDict()

    @functools.wraps(reader)
    def remembered(source):
        path = getattr(source, "filename", source)
        key = (file_identity(path), getattr(source, "name", None))
        if key not in cache:
            cache[key] = reader(source)
            while len(cache) > REMEMBERED:
                cache.popitem(last=False)
        cache.move_to_end(key)
        return copy.deepcopy(cache[key])

    remembered.forget = cache.clear
    return remembered
