"""A package's public names taken from its submodules on first access (PEP 562), so importing one
submodule does not import its siblings' libraries.

    __getattr__, __dir__ = lazy_exports(__name__, {"Validator": "checks", ...})
"""

from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, homes: dict[str, str]):
    """The module `__getattr__` and `__dir__` of `package`: name -> `package.<homes[name]>.<name>`,
    imported on first access and kept in the package's namespace."""
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str):
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{homes[name]}"), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted({*namespace, *homes})

    return __getattr__, __dir__
