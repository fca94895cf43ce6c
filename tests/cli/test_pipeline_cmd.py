"""`legplan pipeline run|show` end to end (the stages themselves are `legplan inspect`, which is
always there: a stage that fails because inspect writes no output, and dry-run/spec-error paths)."""

import yaml
from click.testing import CliRunner

from legplan.artefacts import write_artefact, write_summary
from legplan.cli.main import cli


def write(tmp_path, stages):
    path = tmp_path / "pipe.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "stages": stages}))
    return path


def test_dry_run_lists_what_would_run_and_why(tmp_path):
    spec = tmp_path / "in.txt"
    spec.write_text("x")
    path = write(tmp_path, [
        {"name": "a", "command": ["inspect", str(spec)], "inputs": [str(spec)], "output": "a.h5"},
        {"name": "b", "command": ["inspect", "{stages.a.output}"], "output": "b.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "--out", str(tmp_path / "o"),
                                      "--dry-run"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == "run  a: no output yet"
    assert lines[2] == "run  b: upstream stage 'a' will run"
    assert lines[3].startswith("     legplan inspect ") and lines[3].endswith("b.h5 --overwrite")
    assert not (tmp_path / "o").exists()


def test_dry_run_reports_up_to_date_and_changed_input(tmp_path):
    src = tmp_path / "in.txt"
    src.write_text("x")
    out = tmp_path / "o"
    argv = ["inspect", str(src), "-o", str(out / "a.h5"), "--overwrite"]
    with write_artefact(out / "a.h5", "map", inputs=[src], command=["legplan", *argv]) as f:
        write_summary(f, {"n": 1})
    path = write(tmp_path, [{"name": "a", "command": ["inspect", str(src)], "inputs": [str(src)],
                             "output": "a.h5"}])
    dry = ["pipeline", "run", str(path), "--out", str(out), "--dry-run"]
    assert CliRunner().invoke(cli, dry).stdout.splitlines()[0] == "skip a: up to date"
    src.write_text("y")
    assert CliRunner().invoke(cli, dry).stdout.splitlines()[0] == f"run  a: input changed: {src}"


def test_failed_stage_exit_1_names_stage_and_reason(tmp_path):
    path = write(tmp_path, [
        {"name": "a", "command": ["inspect", str(tmp_path / "nothing.h5")], "output": "a.h5"},
        {"name": "b", "command": ["inspect", "{stages.a.output}"], "output": "b.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "--out", str(tmp_path / "o"), "-q"])
    assert result.exit_code == 1
    assert "stage 'a' failed" in result.stderr
    assert "exit 2" in result.stderr
    assert "skipped b: upstream stage 'a' failed" in " ".join(result.stderr.split())
    assert (tmp_path / "o" / "logs" / "a.log").exists()


def test_bad_pipeline_file_exit_2_one_line(tmp_path):
    path = write(tmp_path, [{"name": "a", "command": ["inspect", "{stages.zz.output}"], "output": "a"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path)])
    assert result.exit_code == 2
    assert "references unknown stage 'zz'" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_missing_declared_input_exit_2(tmp_path):
    path = write(tmp_path, [{"name": "a", "command": ["inspect"], "inputs": [str(tmp_path / "no.yaml")],
                             "output": "a.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "field 'stages.a.inputs'" in result.stderr and "no.yaml does not exist" in result.stderr


def test_show_prints_resolved_commands(tmp_path):
    path = write(tmp_path, [
        {"name": "b", "command": ["inspect", "{stages.a.output}"], "output": "b.h5"},
        {"name": "a", "command": ["inspect", "x"], "output": "a.h5", "params": {"json": True}}])
    result = CliRunner().invoke(cli, ["pipeline", "show", str(path), "--out", "o"])
    assert result.exit_code == 0
    first, second = result.stdout.splitlines()
    assert first.startswith("a: legplan inspect x --json -o ") and second.startswith("b (after a): ")
