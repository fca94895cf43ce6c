"""`legplan pipeline run|show` end to end: real `map build` and `report` stages run and then are up
to date; `legplan map show` stages for a stage that fails on a missing input, dry-run/spec-error
paths, and stages the click commands refuse."""

from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from legplan.artefacts import open_artefact, read_provenance, read_summary, sha256_file, write_artefact, write_summary
from legplan.cli.console import verbosity
from legplan.cli.main import cli


def write(tmp_path, stages):
    path = tmp_path / "pipe.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "stages": stages}))
    return path


def test_dry_run_lists_what_would_run_and_why(tmp_path):
    spec = tmp_path / "in.txt"
    spec.write_text("x")
    path = write(tmp_path, [
        {"name": "a", "command": ["map", "show", str(spec)], "inputs": [str(spec)], "output": "a.h5"},
        {"name": "b", "command": ["map", "show", "{stages.a.output}"], "output": "b.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(tmp_path / "o"),
                                      "--dry-run"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == "run  a: no output yet"
    assert lines[2] == "run  b: upstream stage 'a' will run"
    assert lines[3].startswith("     legplan map show ") and lines[3].endswith("b.h5 --overwrite")
    assert not (tmp_path / "o").exists()


def test_dry_run_reports_up_to_date_and_changed_input(tmp_path):
    src = tmp_path / "in.txt"
    src.write_text("x")
    out = tmp_path / "o"
    argv = ["map", "show", str(src), "-o", str(out / "a.h5"), "--overwrite"]
    with write_artefact(out / "a.h5", "map", inputs=[src], command=["legplan", *argv]) as f:
        write_summary(f, {"n": 1})
    path = write(tmp_path, [{"name": "a", "command": ["map", "show", str(src)], "inputs": [str(src)],
                             "output": "a.h5"}])
    dry = ["pipeline", "run", str(path), "-o", str(out), "--dry-run"]
    assert CliRunner().invoke(cli, dry).stdout.splitlines()[0] == "skip a: up to date"
    src.write_text("y")
    assert CliRunner().invoke(cli, dry).stdout.splitlines()[0] == f"run  a: input changed: {src}"


def test_failed_stage_exit_1_names_stage_and_reason(tmp_path):
    path = write(tmp_path, [
        {"name": "a", "command": ["map", "show", str(tmp_path / "nothing.h5")], "output": "a.png"},
        {"name": "b", "command": ["map", "show", "{stages.a.output}"], "output": "b.png"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(tmp_path / "o"), "-q"])
    assert result.exit_code == 1
    assert "stage 'a' failed" in result.stderr
    assert "exit 2" in result.stderr
    assert "skipped b: upstream stage 'a' failed" in " ".join(result.stderr.split())
    assert (tmp_path / "o" / "logs" / "a.log").exists()


@pytest.mark.parametrize("stage, problem", [
    ({"command": ["map", "shw", "{stages.a.output}"]}, "unknown command 'legplan map shw'"),
    ({"command": ["map"]}, "'legplan map' needs a subcommand (build, import, show)"),
    ({"command": ["map", "show", "{stages.a.output}"], "params": {"dpi": 90}}, "No such option '--dpi'"),
    ({"command": ["map", "import", "lidar", "x.pgm"]}, "'lidar' is not one of 'ros'"),
    ({"command": ["map", "import", "heightmap", "x.npy"], "params": {"resolution": "nan"}},
     "Invalid value for '--resolution'"),
    ({"command": ["map", "show", "{stages.a.output}"], "params": {"quiet": True, "help": True}},
     "would only print its help"),
])
def test_stage_the_command_refuses_is_exit_2_before_any_stage_runs(tmp_path, stage, problem):
    spec = tmp_path / "flat.yaml"
    spec.write_text("resolution: 0.1\nextent: {x: [0, 1], y: [0, 1]}\n")
    path = write(tmp_path, [{"name": "a", "command": ["map", "build", str(spec)], "output": "a.h5"},
                            {"name": "b", "output": "b.png", **stage}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(tmp_path / "o")])
    assert result.exit_code == 2, result.output
    line, = result.stderr.strip().splitlines()
    assert f"{path}: stage 'b': " in line and problem in line, line
    assert not (tmp_path / "o").exists()
    assert verbosity() == 0  # a stage's -q parsed for the check leaves the pipeline's verbosity alone


def test_bad_pipeline_file_exit_2_one_line(tmp_path):
    path = write(tmp_path, [{"name": "a", "command": ["inspect", "{stages.zz.output}"], "output": "a"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path)])
    assert result.exit_code == 2
    assert "references unknown stage 'zz'" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_missing_declared_input_exit_2(tmp_path):
    path = write(tmp_path, [{"name": "a", "command": ["map", "build", str(tmp_path / "no.yaml")],
                             "inputs": [str(tmp_path / "no.yaml")], "output": "a.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "field 'stages.a.inputs'" in result.stderr and "no.yaml does not exist" in result.stderr


def test_show_prints_resolved_commands(tmp_path):
    path = write(tmp_path, [
        {"name": "b", "command": ["inspect", "{stages.a.output}"], "output": "b.h5"},
        {"name": "a", "command": ["inspect", "x"], "output": "a.h5", "params": {"json": True}}])
    result = CliRunner().invoke(cli, ["pipeline", "show", str(path), "-o", "o"])
    assert result.exit_code == 0
    first, second = result.stdout.splitlines()
    assert first.startswith("a: legplan inspect x --json -o ") and second.startswith("b (after a): ")


def test_real_stages_publish_linked_artefacts_then_are_up_to_date(tmp_path):
    """`map build` then `report` of its map, the real commands: each output is an artefact whose
    provenance holds its input's sha256; a second run runs nothing and leaves them as they are."""
    spec = Path(__file__).resolve().parents[2] / "maps" / "flat.yaml"
    path = write(tmp_path, [
        {"name": "map", "command": ["map", "build", str(spec)], "inputs": [str(spec)], "output": "map.h5"},
        {"name": "report", "command": ["report", "{stages.map.output}"], "inputs": ["{stages.map.output}"],
         "output": "report/", "provenance": "report/report.h5", "params": {"title": "flat ground"}}])
    out = tmp_path / "o"
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "ran map (no output yet)" in result.stderr and "ran report (no output yet)" in result.stderr
    with open_artefact(out / "map.h5", kind="map") as f:
        assert [r["sha256"] for r in read_provenance(f)["inputs"]] == [sha256_file(spec)]
        assert "terrain/height" in f
    with open_artefact(out / "report" / "report.h5", kind="report") as f:
        assert [r["sha256"] for r in read_provenance(f)["inputs"]] == [sha256_file(out / "map.h5")]
        assert read_summary(f)["figures"][0] == 1 and read_summary(f)["figure_failures"][0] == 0
    assert "<title>flat ground</title>" in (out / "report" / "index.html").read_text()
    before = {p: p.read_bytes() for p in (out / "map.h5", out / "report" / "report.h5")}
    again = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(out)])
    assert again.exit_code == 0, again.output
    assert "map: up to date" in again.stderr and "report: up to date" in again.stderr
    assert {p: p.read_bytes() for p in before} == before


def test_a_malformed_scheduler_is_one_line_before_any_stage_and_the_variable_reaches_batch_commands(tmp_path):
    spec = tmp_path / "in.txt"
    spec.write_text("x")
    path = write(tmp_path, [{"name": "a", "command": ["map", "show", str(spec)], "inputs": [str(spec)],
                             "output": "a.h5"}])
    result = CliRunner().invoke(cli, ["pipeline", "run", str(path), "-o", str(tmp_path / "o"), "--scheduler", "nowhere"])
    assert result.exit_code == 2 and "--scheduler: expected 'local' or an address" in result.output
    assert not (tmp_path / "o").exists()
    # a many-item command falls back to LEGPLAN_SCHEDULER, the variable `pipeline run --scheduler` sets
    out = tmp_path / "traj.h5"
    result = CliRunner().invoke(cli, ["dyn", "plan", str(spec), "--start", "0", "0", "0", "--goal", "1", "0", "0",
                                      "-o", str(out)], env={"LEGPLAN_SCHEDULER": "nowhere"})
    assert result.exit_code == 2 and "--scheduler: expected 'local' or an address" in result.output, result.output
    assert not out.exists()
