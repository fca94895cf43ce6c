"""Keep `import scipy.sparse` from importing numpy.f2py, numpy.testing, numpy.ma and Cython.

scipy's vendored array-API namespace for numpy (`scipy._lib.array_api_compat.numpy`, imported by every
scipy subpackage, scipy.sparse included) copies numpy's namespace with `from numpy import *` and a
`hasattr` over `dir(numpy)`, which imports numpy's lazily loaded submodules — f2py (with argparse),
testing (with unittest), ma, polynomial, strings, the numpy.core shim, ... — none of which legplan
uses through scipy's namespace, at a cost of about a third
of scipy.sparse's import time. `install()` hooks that one module's first import: while it runs, numpy
lists none of those submodules, and afterwards the namespace gets them on first access (PEP 562
`__getattr__` forwarding to numpy), so it still offers every name numpy does. Any surprise in the
hook (another scipy layout) falls back to the plain import. While the hook waits, it also answers
"no such module" to scipy's test utilities (`scipy._lib._testutils`, imported by every scipy
subpackage), which look for Cython only to decide whether to run Cython API tests.
"""

from __future__ import annotations

import importlib.util
import sys

TARGET = "scipy._lib.array_api_compat.numpy"
DEFERRED = frozenset({"f2py", "testing", "ma", "matlib", "ctypeslib", "polynomial", "rec", "char", "strings",
                      "core"})


class _Finder:
    """Finds nothing itself; wraps the loader of `TARGET` the first time it is imported (a meta path
    finder by protocol: `importlib.abc` would import `importlib.resources` and `tempfile` at start-up)."""

    def find_spec(self, name, path, target=None):
        if name == "cython" and _importing("scipy._lib._testutils"):
            raise ModuleNotFoundError("legplan: scipy's test utilities run without Cython", name=name)
        if name != TARGET:
            return None
        uninstall()
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _Loader(spec.loader)
        return spec


class _Loader:
    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        import numpy

        saved_all, had_dir = numpy.__all__, "__dir__" in vars(numpy)
        listed = numpy.__dir__ if had_dir else None
        try:
            numpy.__all__ = [n for n in saved_all if n not in DEFERRED]
            if had_dir:
                numpy.__dir__ = lambda: [n for n in listed() if n not in DEFERRED]
            self.loader.exec_module(module)
        finally:
            numpy.__all__ = saved_all
            if had_dir:
                numpy.__dir__ = listed
        if "__getattr__" not in vars(module):
            def forward(name):  # the deferred submodules, from numpy on first access
                if name in DEFERRED:
                    return getattr(numpy, name)
                raise AttributeError(f"module {module.__name__!r} has no attribute {name!r}")
            module.__getattr__ = forward


def _importing(module: str) -> bool:
    """Is `module` being imported right now (in sys.modules, its first execution not finished)?"""
    spec = getattr(sys.modules.get(module), "__spec__", None)
    return bool(getattr(spec, "_initializing", False))


_finder = _Finder()


def install() -> None:
    """Hook the first import of scipy's array-API numpy namespace (no effect once it is imported)."""
    if TARGET not in sys.modules and _finder not in sys.meta_path:
        sys.meta_path.insert(0, _finder)


def uninstall() -> None:
    if _finder in sys.meta_path:
        sys.meta_path.remove(_finder)
