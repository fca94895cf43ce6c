"""Every `legplan` command of README.md and docs/*.md, from a temporary directory outside the
repository, in the document's order as a user would type them (one directory per document).

The quick ones (map build / import, robot, pipeline show, inspect) run for real and must exit 0;
the long ones (planning, learning, simulation) are parsed by their click command, every value
converted (poses, shipped scenario names, numbers), and every input file must exist there: a
shipped scenario, or a file an earlier command of the block wrote (its -o) or the block created
(`printf ... > tasks.csv`). `hexapod.urdf` stands for the user's URDF (docs/robots.md) and is
copied from tests/data.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RUN = {("map", "build"), ("map", "import"), ("robot", "init"), ("robot", "check"), ("robot", "show"),
       ("robot", "list"), ("pipeline", "show"), ("inspect",)}
OUTPUT_PARAMS = ("output", "out_dir")


def shell_blocks(path: Path) -> list[list[list[str]]]:
    """The ```sh blocks of a document: per block, its command lines split into words, continuation
    lines joined, comments and optional `[...]` groups dropped."""
    blocks = []
    for body in re.findall(r"^```sh\n(.*?)^```", path.read_text(), re.S | re.M):
        lines = []
        for line in body.replace("\\\n", " ").splitlines():
            line = re.sub(r"\s+#\s.*$", "", line)
            line = re.sub(r"\[[^\]]*\]", "", line).strip()
            if line and not line.startswith("#"):
                lines.append(shlex.split(line))
        blocks.append(lines)
    return blocks




def _leaf(words: list[str]) -> tuple[tuple[str, ...], click.Command, list[str]]:
    """The command path, the leaf click command and its arguments of `legplan WORDS...`."""
    command, path, args = cli, [], list(words)
    while (isinstance(command, click.Group) and args
           and command.get_command(click.Context(command), args[0]) is not None):  # loaded on first use
        command = command.get_command(click.Context(command), args[0])
        path.append(args.pop(0))
    return tuple(path), command, args


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: path.name)
def test_documented_commands_run_from_outside_the_repository(document, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROOT / "tests" / "data" / "hexapod.urdf", tmp_path / "hexapod.urdf")
    written: set[Path] = set()
    commands = [words for block in shell_blocks(document) for words in block]
    assert any(words[0] == "legplan" for words in commands) or document.name != "README.md"
    for words in commands:
        if words[0] == "export":
            name, _, value = words[1].partition("=")
            monkeypatch.setenv(name, value.replace("$PWD", str(tmp_path)))
            continue
        if re.fullmatch(r"[A-Z_]+=\$\(python", words[0]):  # NAME=$(python -c "...") sets a shell variable
            name = words[0].split("=", 1)[0]
            code = " ".join(words[2:])[:-1]  # the last ")" closes the "$("
            done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
            monkeypatch.setenv(name, done.stdout.strip())
            continue
        words = [os.path.expandvars(word) for word in words]
        if words[0] == "printf" and words[-2] == ">":
            Path(words[-1]).write_text(words[1].encode().decode("unicode_escape"))
            continue
        if words[0] != "legplan":
            continue
        path, command, args = _leaf(words[1:])
        assert not isinstance(command, click.Group), f"{words}: no such command"
        if path in RUN:
            result = CliRunner().invoke(cli, words[1:])
            assert result.exit_code == 0, f"{shlex.join(words)}: {result.output}"
        ctx = command.make_context(path[-1], list(args))  # every option parsed and converted
        for param in command.params:
            value = ctx.params.get(param.name)
            if value is None or not isinstance(param.type, click.Path):
                continue
            values = value if isinstance(value, tuple) else (value,)
            if param.name in OUTPUT_PARAMS:
                written.update(Path(v).resolve() for v in values)
            elif path not in RUN:
                for v in values:
                    assert Path(v).resolve() in written or Path(v).exists(), f"{shlex.join(words)}: {v} missing"
