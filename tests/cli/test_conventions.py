"""One set of CLI conventions: -o/--overwrite (pipeline's --out/--force deprecated aliases), one
arity rule for poses, did-you-mean for robots and commands, a report output that names a file,
one-line help not cut at abbreviations, `dyn plan --tasks` given a learn task space."""

from pathlib import Path

import click
import pytest
import yaml
from click.testing import CliRunner

from legplan.cli.main import cli, short_help
from legplan.errors import SpecError

ROOT = Path(__file__).resolve().parents[2]


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_pipeline_takes_output_and_overwrite_and_warns_on_the_old_spellings(tmp_path):
    spec = tmp_path / "in.txt"
    spec.write_text("x")
    path = tmp_path / "pipe.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "stages": [
        {"name": "a", "command": ["map", "show", str(spec)], "inputs": [str(spec)], "output": "a.png"}]}))
    new = run("pipeline", "run", path, "-o", tmp_path / "o", "--overwrite", "--dry-run")
    old = run("pipeline", "run", path, "--out", tmp_path / "o", "--force", "--dry-run")
    assert new.exit_code == old.exit_code == 0 and new.stdout == old.stdout
    assert new.stdout.startswith("run  a: ") and str(tmp_path / "o" / "a.png") in new.stdout
    assert new.stderr == ""
    assert "--out is deprecated; use -o/--output" in old.stderr and "--force is deprecated" in old.stderr
    help_text = run("pipeline", "run", "--help").stdout
    assert "--output" in help_text and "--overwrite" in help_text
    assert "--out " not in help_text and "--force" not in help_text


@pytest.mark.parametrize("command", [("steps", "generate"), ("dyn", "plan")])
def test_every_pose_option_takes_x_y_and_an_optional_yaw(command):
    group = cli.get_command(None, command[0])
    sub = group.get_command(None, command[1])
    ctx = sub.make_context(command[1], ["m.h5", "--robot", "scarab2", "--start", "-0.6", "0",
                                        "--goal", "0.6", "-0.1", "0.5", "-o", "x.h5"])
    assert ctx.params["start"] == (-0.6, 0.0, 0.0) and ctx.params["goal"] == (0.6, -0.1, 0.5)
    bad = run(*command, "m.h5", "--robot", "scarab2", "--start", "1", "--goal", "0", "0", "-o", "x.h5")
    assert bad.exit_code == 2 and "--start" in bad.stderr and "expected 2 or 3 finite numbers" in bad.stderr


def test_robot_names_match_case_insensitively_and_hint_the_closest():
    result = run("robot", "show", "SCARAB2")
    assert result.exit_code == 0 and result.stdout.startswith("scarab2: ")
    result = run("robot", "show", "scarab")
    assert result.exit_code == 2 and "unknown robot (did you mean 'scarab2'?)" in result.stderr
    result = run("robot", "show", "zzzz")
    assert result.exit_code == 2 and "did you mean" not in result.stderr and "known: " in result.stderr


@pytest.mark.parametrize("typed, hint", [(["steps", "plan"], "'step plan'"),
                                         (["step", "simulate"], "'dyn simulate'"),
                                         (["stpe"], "'step'")])
def test_a_mistyped_command_names_the_closest_one(typed, hint):
    result = run(*typed, "--help")
    assert result.exit_code == 2 and hint in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_a_report_output_named_like_a_file_is_refused(tmp_path):
    from fake_artefacts import write_map

    result = run("report", write_map(tmp_path / "m.h5"), "-o", tmp_path / "report.html")
    assert result.exit_code == 2 and "give a directory (-o " in result.stderr
    assert not (tmp_path / "report.html").exists()


def test_one_line_help_runs_past_abbreviations():
    def commands(group, path=()):
        ctx = click.Context(group)
        for name in group.list_commands(ctx):
            sub = group.get_command(ctx, name)
            yield (*path, name), sub
            if hasattr(sub, "commands"):
                yield from commands(sub, (*path, name))

    dyn_show = cli.get_command(click.Context(cli), "dyn").commands["show"]
    assert short_help(dyn_show, 200).startswith("PNG of TRAJ: base, feet and forces over time (Fig. 3);")
    for path, sub in commands(cli):
        line = sub.get_short_help_str(200)
        assert not line.endswith(("Fig.", "eq.", "Eq.", "Sec.", "e.g.", "i.e.")), path
    listing = run("dyn", "--help").stdout
    assert "(Fig.\n" not in listing and "(Fig. 3)" in listing


def test_dyn_tasks_refuses_a_learn_task_space_with_a_clear_message():
    from legplan.dyn.tasks import read_tasks

    with pytest.raises(SpecError, match="is a learn task space .* not a tasks file; --tasks takes one task per row"):
        read_tasks(ROOT / "tasks" / "single_pallet_walk.yaml")
