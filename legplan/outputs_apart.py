"""Outputs kept apart from inputs: no command may write over a file it reads.

A command's outputs are compared with every input it names before any work starts, so `dyn plan
M.h5 -o M.h5 --overwrite` (or a symbolic or hard link to M.h5) is refused as bad input instead of
replacing the map it plans on. Two paths are the same file when their real paths are equal or when
both exist with the same device and inode (`os.path.samefile`). An output directory that a command
replaces whole (a report) must not hold an input anywhere below it; one that a command writes named
files into (a robot folder's `robot.yaml`) is compared by those files only.

    outputs = [Output("--output", "traj.h5")]
    inputs = [Input("MAP", "map.h5")]
    refuse_overlap(outputs, inputs)        # ArtefactError naming both, exit 2 on the command line

The click side (`legplan.cli.guard`) finds a command's outputs by their parameter type
(`legplan.cli.options.OutputPath`) and treats every other parameter value that names an existing
file as an input, so the rule holds for every command in one place.
"""

from __future__ import annotations

import fnmatch
import os
from dataclasses import dataclass
from pathlib import Path

from legplan.errors import ArtefactError


@dataclass(frozen=True)
class Output:
    """An output named by option `label`: a file, or a directory replaced whole (`whole_directory`),
    or a directory into which the command writes only `files` (names or shell patterns such as
    `dataset_*.h5`)."""

    label: str
    path: str | os.PathLike
    whole_directory: bool = False
    files: tuple[str, ...] = ()

    def targets(self) -> list[Path]:
        """The paths this output writes (the directory itself when it is replaced whole)."""
        path = Path(self.path)
        return [path / name for name in self.files] if self.files else [path]

    def writes(self, source: Path) -> bool:
        """Whether writing this output would replace the existing file or directory `source`."""
        if self.whole_directory and not self.files:
            return _inside(source, Path(self.path))
        if self.files:
            in_folder = os.path.realpath(source.parent) == os.path.realpath(self.path)
            return any(_same_file(Path(self.path) / name, source)
                       or (in_folder and fnmatch.fnmatchcase(source.name, name)) for name in self.files)
        return _same_file(Path(self.path), source)


@dataclass(frozen=True)
class Input:
    """An input file named by parameter `label`."""

    label: str
    path: str | os.PathLike


def _same_file(a: Path, b: Path) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # either one does not exist: only the real paths could match
        return False


def _inside(path: Path, directory: Path) -> bool:
    """Whether `path` (an existing input) lies below or at `directory`."""
    real, top = os.path.realpath(path), os.path.realpath(directory)
    return real == top or real.startswith(top.rstrip(os.sep) + os.sep)


def refuse_overlap(outputs: list[Output], inputs: list[Input]) -> None:
    """Raise `ArtefactError` when an output would write over one of `inputs` (the first such pair,
    in the order given); also when two outputs name the same file."""
    for output in outputs:
        for source in inputs:
            if output.writes(Path(source.path)):
                where = "holds" if output.whole_directory and not output.files else "names"
                raise ArtefactError(
                    f"{output.path}: {output.label} {where} the input {source.label} "
                    f"'{source.path}', which writing it would replace; choose another output")
    seen: list[tuple[Output, Path]] = []
    for output in outputs:
        for target in output.targets():
            for other, other_target in seen:
                if _same_file(target, other_target):
                    raise ArtefactError(f"{output.path}: {output.label} and {other.label} name the same file")
            seen.append((output, target))
