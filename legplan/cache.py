"""Results of `scipy.ndimage` filters on map grids, kept on disk and keyed by their inputs' content.

    smooth = filtered("gaussian_filter", height, sigma, mode="nearest")

is `scipy.ndimage.gaussian_filter(height, sigma, mode="nearest")`. Every run of a command on the same
map computes the same filtered grids (the optimizer's terrain model, the independent check's surface);
the first run stores each result, later runs read it back, and neither computes it nor imports
scipy.ndimage (with the scipy.special it pulls in, the largest import a planning command would
otherwise make for a few filter calls).

A result is found by the sha256 of everything it depends on: the filter's name, every argument (an
array by its dtype, shape and bytes; anything else by its `repr`) and the numpy and scipy versions.
Changed inputs or libraries give another key, so a stored result is never stale; it is the bytes the
filter returned. Files are written to a temporary name and renamed (concurrent runs never read half a
file); an unreadable or damaged file is recomputed and replaced; a folder that cannot be written only
means the result is computed every time.

Folder: `$LEGPLAN_CACHE_DIR`, else `$XDG_CACHE_HOME/legplan`, else `~/.cache/legplan`;
`LEGPLAN_CACHE_DIR=` (empty) turns the store off.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import numpy as np

ENVIRONMENT = "LEGPLAN_CACHE_DIR"


def cache_dir() -> Path | None:
    """The store's folder (not created here), or None when `LEGPLAN_CACHE_DIR` is set empty."""
    given = os.environ.get(ENVIRONMENT)
    if given is not None:
        return Path(given) if given else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "legplan"


def _scipy_version() -> str:
    """scipy's version without importing more of scipy than its top package."""
    module = sys.modules.get("scipy")
    if module is None:
        import scipy as module
    return module.__version__


def key(function: str, args: tuple, kwargs: dict) -> str:
    """sha256 of a filter call: its name, its arguments' content and the libraries' versions."""
    digest = hashlib.sha256(f"{function}\0numpy {np.__version__}\0scipy {_scipy_version()}".encode())
    for name, value in [*((str(i), a) for i, a in enumerate(args)), *sorted(kwargs.items())]:
        if isinstance(value, np.ndarray):
            value = np.ascontiguousarray(value)
            digest.update(f"\0{name}=array {value.dtype.str} {value.shape}\0".encode())
            digest.update(value.data)
        else:
            digest.update(f"\0{name}={value!r}".encode())
    return digest.hexdigest()


def filtered(function: str, *args, **kwargs) -> np.ndarray:
    """`scipy.ndimage.<function>(*args, **kwargs)` (an array result), from the store when it holds it
    (see the module docstring). Array arguments must be numpy arrays (hashed by content)."""
    folder = cache_dir()
    path = None if folder is None else folder / f"{function}-{key(function, args, kwargs)}.npy"
    if path is not None:
        try:
            return np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError):  # not stored yet, unreadable or damaged: compute it
            pass
    from scipy import ndimage  # only when the result is not stored

    result = getattr(ndimage, function)(*args, **kwargs)
    if path is not None:
        _store(path, result)
    return result


def _store(path: Path, result: np.ndarray) -> None:
    """Write `result` to `path` atomically; a folder that cannot be written is left as it is."""
    import tempfile  # only a first run on a map stores: later runs start without it

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{path.stem[:32]}-", suffix=".npy", dir=path.parent)
        try:
            with os.fdopen(handle, "wb") as f:
                np.save(f, result, allow_pickle=False)
            os.replace(temporary, path)
        except BaseException:
            os.unlink(temporary)
            raise
    except OSError:
        pass
