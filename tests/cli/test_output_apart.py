"""No command writes over its own input (hardening, data-loss class): for every command of the click
tree with an output, every way of naming one of its inputs as the output (the same path, another
spelling, a symbolic or hard link, a file inside an output directory the command replaces or writes
into) is refused before any work: exit 2, one line naming the output and the input, every input
byte-identical."""

from __future__ import annotations

import os
from pathlib import Path

import click
import pytest
from bad_input_support import assert_refused, few, invoke, leaf_commands
from hypothesis import given
from hypothesis import strategies as st

from legplan.outputs_apart import Input, Output, refuse_overlap
from legplan.cli.guard import ROBOT_PARAMS
from legplan.cli.options import Numbers, OutputPath
from legplan.errors import ArtefactError

CONTENT = b"an input that no command may replace\n"


def _outputs(command) -> list[click.Parameter]:
    return [p for p in command.params if isinstance(p.type, OutputPath)]


def _inputs(command) -> list[click.Parameter]:
    return [p for p in command.params
            if isinstance(p.type, click.Path) and p.type.file_okay and not isinstance(p.type, OutputPath)]


WRITERS = [(path, command) for path, command in leaf_commands() if _outputs(command)]
CASES = [(path, command, source) for path, command in WRITERS for source in _inputs(command)]


def test_every_output_parameter_is_an_output_path():
    """An option spelled -o/--output/--png/--out of any command is typed OutputPath, so the guard
    sees it; an --overwrite flag always comes with one."""
    for path, command in leaf_commands():
        names = {opt for p in command.params for opt in getattr(p, "opts", ())}
        for param in command.params:
            if set(param.opts) & {"-o", "--output", "--png"}:
                assert isinstance(param.type, OutputPath), f"{' '.join(path)} {param.opts}"
        if "--overwrite" in names:
            assert _outputs(command), f"{' '.join(path)} has --overwrite but no OutputPath"


def _filler(param, tmp_path: Path) -> list[str]:
    kind = param.type
    if isinstance(kind, click.Choice):
        text = kind.choices[0]
    elif isinstance(kind, Numbers):
        return ["0.5"] * min(kind.counts)
    elif isinstance(kind, (click.types.FloatParamType, click.types.IntParamType)):
        text = "1"
    elif param.name in ROBOT_PARAMS:
        text = "anymal"
    else:
        text = str(tmp_path / f"{param.name}.in")
    return [text] * max(param.nargs, 1)


def _target(output: OutputPath, named: Path, spelling: str, tmp_path: Path) -> tuple[Path, Path]:
    """(input path, output path): the output names the input `named` in `spelling`."""
    if output.files or output.whole_directory:
        folder = tmp_path / "out"
        folder.mkdir(exist_ok=True)
        name = output.files[0].replace("*", "0") if output.files else "kept.h5"
        source = folder / name
        source.write_bytes(CONTENT)
        return source, folder
    source = named
    source.write_bytes(CONTENT)
    if spelling == "relative":
        return source, Path(os.path.relpath(source))
    if spelling == "dotted":
        return source, source.parent / "." / source.name
    if spelling in ("symlink", "hardlink"):
        link = tmp_path / f"{spelling}.h5"
        (link.symlink_to if spelling == "symlink" else link.hardlink_to)(source)
        return source, link
    return source, source


@pytest.mark.parametrize("path,command,source", CASES,
                         ids=[f"{' '.join(p)} {s.name}" for p, _, s in CASES])
@given(spelling=st.sampled_from(["same", "relative", "dotted", "symlink", "hardlink"]),
       overwrite=st.booleans())
@few(5)
def test_an_output_naming_an_input_is_refused(tmp_path_factory, path, command, source, spelling, overwrite):
    tmp_path = tmp_path_factory.mktemp("apart")
    args, files = [*path], []
    output = _outputs(command)[0]
    named, target = _target(output.type, tmp_path / f"{source.name}.in", spelling, tmp_path)
    for param in command.params:
        if param is output or not (param.required or param is source):
            continue
        values = [str(named)] * max(param.nargs, 1) if param is source else _filler(param, tmp_path)
        if isinstance(param.type, click.Path):
            for value in values:
                Path(value).write_bytes(CONTENT)
                files.append(Path(value))
        args += values if isinstance(param, click.Argument) else [param.opts[-1], *values]
    args += [output.opts[-1], target]
    if overwrite and any("--overwrite" in p.opts for p in command.params):
        args.append("--overwrite")
    line = assert_refused(invoke(args), str(target))
    assert "input" in line
    for file in files:
        assert file.read_bytes() == CONTENT, f"{file} changed"


def test_refuse_overlap_by_kind(tmp_path):
    data = tmp_path / "map.h5"
    data.write_bytes(CONTENT)
    other = tmp_path / "traj.h5"
    refuse_overlap([Output("-o", other)], [Input("MAP", data)])
    with pytest.raises(ArtefactError, match="MAP"):
        refuse_overlap([Output("-o", tmp_path / "sub" / ".." / "map.h5")], [Input("MAP", data)])
    with pytest.raises(ArtefactError, match="holds"):
        refuse_overlap([Output("-o", tmp_path, whole_directory=True)], [Input("MAP", data)])
    refuse_overlap([Output("-o", tmp_path, files=("robot.yaml",))], [Input("URDF", data)])
    with pytest.raises(ArtefactError, match="URDF"):
        refuse_overlap([Output("-o", tmp_path, files=("*.h5",))], [Input("URDF", data)])
    with pytest.raises(ArtefactError, match="same file"):
        refuse_overlap([Output("-o", other), Output("--png", other)], [])
