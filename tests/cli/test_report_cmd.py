"""`legplan report` end to end on fake artefacts."""

from click.testing import CliRunner
from fake_artefacts import write_map

from legplan.cli.main import cli


def test_report_writes_index_and_refuses_existing(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    out = tmp_path / "rep"
    result = CliRunner().invoke(cli, ["report", str(map_path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "cells_x" in (out / "index.html").read_text()
    assert "1 artefacts, 1 figures, 0 figure failures" in result.stderr
    again = CliRunner().invoke(cli, ["report", str(map_path), "-o", str(out)])
    assert again.exit_code == 2 and "output exists (use --overwrite" in again.stderr


def test_report_bad_input_exit_2(tmp_path):
    result = CliRunner().invoke(cli, ["report", str(tmp_path / "none.h5"), "-o", str(tmp_path / "r")])
    assert result.exit_code == 2 and "none.h5: no such file" in result.stderr
    assert not (tmp_path / "r").exists()


def test_report_of_malformed_artefact_exit_2_one_line(tmp_path):
    from legplan.artefacts import write_artefact

    with write_artefact(tmp_path / "steps.h5", "steps") as f:   # a steps artefact without /q
        f.attrs.update(leg_names='["a", "b", "c"]', joint_names='["j"]', robot="scarab2", robot_sha256="x")
    result = CliRunner().invoke(cli, ["report", str(tmp_path / "steps.h5"), "-o", str(tmp_path / "r")])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [f"Error: {tmp_path / 'steps.h5'}: missing dataset '/q'"]
    assert not (tmp_path / "r").exists()
