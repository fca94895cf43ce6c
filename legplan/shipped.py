"""The scenarios that ship with legplan, addressable by name from any directory.

The repository's `maps/`, `pipelines/` and `tasks/` folders are package data under
`legplan/scenarios/` (symbolic links in the source tree; a wheel holds the files, as for the
robots of `legplan.robots.registry`), read through `importlib.resources`. Pipelines and task spaces
name their maps relative to their own folder (`../maps/gap_crossing.yaml`), which holds in both.

`resolve_shipped` gives a command's input file: the path as given when it exists; else the shipped
file it names, by name (`gap_crossing`, `pallet_climb.yaml`) or by its path in the repository
(`maps/gap_crossing.yaml`, `maps/ros/warehouse.yaml`), so README's commands run from anywhere.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from legplan.errors import LegplanError, did_you_mean

KINDS = ("maps", "pipelines", "tasks")
"""The shipped folders; each also names the kind of a command's input."""

INITIALIZERS = "initializers"
"""The shipped trained initializers, a folder of the shipped `tasks/`: NAME.h5, an init.h5 trained on
the task space tasks/NAME.yaml and readied by `legplan learn ship`, whose provenance records how it
was made (command, seed, datasets' sha256) and how it did on held-out tasks (`legplan.learn.shipping`)."""


def package_data(name: str) -> Path:
    """The package data `legplan/<name>`: in the package's folder when legplan is installed as
    folders (a wheel, an editable install), otherwise through `importlib.resources` (imported only
    then: it brings `tempfile`, `zipfile` and more into every command's start-up)."""
    locations = getattr(sys.modules["legplan"].__spec__, "submodule_search_locations", None) or []
    for folder in map(Path, locations):
        if (folder / "__init__.py").is_file():
            return folder / name
    from importlib.resources import files

    return Path(str(files("legplan") / name))


def shipped_root() -> Path:
    """The folder holding the shipped `maps/`, `pipelines/` and `tasks/` (links resolved: the
    repository's folders in a source checkout, so messages and provenance name them)."""
    return package_data("scenarios")


def shipped_dir(kind: str) -> Path:
    return (shipped_root() / kind).resolve()


def list_shipped(kind: str) -> list[str]:
    """Names (file stems) of the shipped YAML files of `kind`, sorted."""
    folder = shipped_dir(kind)
    return sorted(path.stem for path in folder.glob("*.yaml")) if folder.is_dir() else []


def shipped_initializer(name: str) -> Path | None:
    """The shipped initializer of the task space `name` (its init.h5), or None when none ships."""
    if not name or os.sep in name or name.startswith("."):
        return None
    path = shipped_dir("tasks") / INITIALIZERS / f"{name}.h5"
    return path if path.is_file() else None


def list_shipped_initializers() -> list[str]:
    """Names of the task spaces a trained initializer ships for, sorted."""
    folder = shipped_dir("tasks") / INITIALIZERS
    return sorted(path.stem for path in folder.glob("*.h5")) if folder.is_dir() else []


def resolve_shipped(given: str | os.PathLike, kind: str) -> Path:
    """The input file `given` names: itself when it exists, else a shipped file of `kind` by name
    or by its repository path; a `LegplanError` naming the shipped ones when neither exists."""
    path = Path(given)
    if path.exists():
        return path
    text = str(given)
    candidates = [shipped_root() / text, shipped_dir(kind) / text]
    if not path.suffix:
        candidates.append(shipped_dir(kind) / f"{text}.yaml")
    for candidate in candidates:
        if candidate.is_file():
            return candidate.resolve()
    names = list_shipped(kind)
    hint = did_you_mean(path.stem, names) if os.sep not in text or text.startswith(f"{kind}/") else ""
    raise LegplanError(f"{given}: no such file, nor a shipped {kind[:-1]}{hint} "
                       f"(shipped {kind}: {', '.join(names) or 'none'})")
